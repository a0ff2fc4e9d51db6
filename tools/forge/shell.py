"""Room shells: Infinigen's floor and wall materials baked to seamless base-colour textures.
A square of the material's tile size is baked (every shader's base colour as emission), then
made seamless by blending it with itself shifted half a tile (weights fading towards the
edges), so a floor or wall repeats it without a visible seam."""

import logging
from pathlib import Path

import bpy
import numpy as np

import blender
import catalogue
import recipes

log = logging.getLogger("forge")
SIZE = 512
FIRST_SEED = 7  # shell texture i is dressed with seed FIRST_SEED + i
JPEG_QUALITY = 88


def seamless(pixels):
    """`pixels` (n × n × c) blended with its half-shifted copy: equal to the copy at the edges
    (where the copy is continuous across the wrap), to itself in the middle."""
    n = pixels.shape[0]
    ramp = 1.0 - np.abs(np.linspace(-1.0, 1.0, n))  # 0 at the edges, 1 in the middle
    weight = np.minimum(ramp[:, None], ramp[None, :])[..., None] ** 0.5
    shifted = np.roll(pixels, (n // 2, n // 2), axis=(0, 1))
    return weight * pixels + (1.0 - weight) * shifted


def bake_texture(texture, seed, out: Path):
    """Bake recipes.ShellTexture `texture` with `seed` to `out`/shell/<name>.jpg."""
    blender.reset()
    blender.seed_infinigen(seed)
    bpy.ops.mesh.primitive_plane_add(size=texture.tile, location=(0, 0, 0))
    plane = bpy.context.active_object
    blender.dress_material(plane, texture.module, texture.material)
    image = blender.bake(plane, SIZE, texture.name, unwrap=False)
    pixels = np.array(image.pixels[:]).reshape(SIZE, SIZE, 4)
    pixels[..., :3] = seamless(pixels[..., :3])
    image.pixels[:] = pixels.ravel()
    path = out / "shell" / f"{texture.name}.jpg"
    path.parent.mkdir(parents=True, exist_ok=True)
    image.filepath_raw = str(path)
    image.file_format = "JPEG"
    bpy.context.scene.render.image_settings.quality = JPEG_QUALITY
    image.save_render(str(path), scene=bpy.context.scene)


def forge_shell(out: Path):
    """Every room-shell texture of recipes.SHELL baked into `out`, and the catalogue's
    `shells` replaced by their entries."""
    catalogue_path = out / catalogue.FILE
    pack = catalogue.read(catalogue_path)
    shells = []
    for index, texture in enumerate(recipes.SHELL):
        seed = FIRST_SEED + index
        bake_texture(texture, seed, out)
        shells.append(catalogue.shell_entry(texture, seed, out))
        log.info("shell %s: %s.%s baked", texture.name, texture.module, texture.material)
    pack["shells"] = shells
    catalogue.write(catalogue_path, pack)
