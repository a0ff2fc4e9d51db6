"""Room shells: Infinigen's floor and wall materials baked to seamless base-colour textures.
A square of the material's tile size is baked (every shader's base colour as emission), then
made seamless by blending it with itself shifted half a tile (weights fading towards the
edges), so a floor or wall repeats it without a visible seam."""

import hashlib
import logging
from pathlib import Path

import bpy
import numpy as np

import forge
import recipes

log = logging.getLogger("forge")
SIZE = 512


def seamless(pixels):
    """`pixels` (n × n × c) blended with its half-shifted copy: equal to the copy at the edges
    (where the copy is continuous across the wrap), to itself in the middle."""
    n = pixels.shape[0]
    ramp = 1.0 - np.abs(np.linspace(-1.0, 1.0, n))  # 0 at the edges, 1 in the middle
    weight = np.minimum(ramp[:, None], ramp[None, :])[..., None] ** 0.5
    shifted = np.roll(pixels, (n // 2, n // 2), axis=(0, 1))
    return weight * pixels + (1.0 - weight) * shifted


def forge_shell(out: Path):
    catalogue_path = out / "catalogue.json"
    pack = forge.read_catalogue(catalogue_path)
    shells = []
    for variant, (name, kind, (module, cls), tile) in enumerate(recipes.SHELL):
        forge.reset()
        np.random.seed(7 + variant)
        bpy.ops.mesh.primitive_plane_add(size=tile, location=(0, 0, 0))
        plane = bpy.context.active_object
        forge.dress_material(plane, module, cls, seed=7 + variant)
        image = forge.bake(plane, SIZE, name, unwrap=False)
        pixels = np.array(image.pixels[:]).reshape(SIZE, SIZE, 4)
        pixels[..., :3] = seamless(pixels[..., :3])
        image.pixels[:] = pixels.ravel()
        path = out / "shell" / f"{name}.jpg"
        path.parent.mkdir(parents=True, exist_ok=True)
        image.filepath_raw = str(path)
        image.file_format = "JPEG"
        bpy.context.scene.render.image_settings.quality = 88
        image.save_render(str(path), scene=bpy.context.scene)
        shells.append(
            {
                "name": name,
                "kind": kind,
                "source": "infinigen material",
                "generator": f"{forge.GENERATOR}: materials.{module}.{cls}",
                "seed": 7 + variant,
                "tile": tile,
                "path": f"shell/{name}.jpg",
                "sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
                "license": forge.LICENSE,
            }
        )
        log.info("shell %s: %s.%s baked", name, module, cls)
    pack["shells"] = shells
    forge.write_catalogue(catalogue_path, pack)
