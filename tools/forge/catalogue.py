"""The pack's catalogue (`assets/catalogue.json`, read by dataset/src/assets/catalogue.rs):
what a forged variant or a room-shell texture is recorded as, and reading and writing it
(indented JSON, one trailing newline; entries sorted by class and variant).

Pure Python: the tests write catalogues without Blender.
"""

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path

GENERATOR = "infinigen 1.15.5, bpy 4.2.0"
LICENSE = "BSD-3-Clause (Infinigen, Princeton University)"
FORMAT = "osmab-assets/1"
FILE = "catalogue.json"


@dataclass(frozen=True)
class Measured:
    """What the forge measured of one variant's mesh, as its catalogue entry records it."""

    size: list  # [w, d, h] in metres, 4 decimals
    scale: float  # the uniform scale into the size range (of the two other axes when stretched)
    triangles: int  # as the GLB holds them (the exporter drops degenerate ones)
    supports: list  # surfaces other objects can rest on (dicts)
    under: dict | None  # the floor free under it, or None


def slug(name):
    return name.replace(" ", "-")


def mesh_path(name, variant):
    """Where variant `variant` of class `name` lies, relative to the pack."""
    return f"meshes/{slug(name)}-{variant}.glb"


def sha256(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def read(path):
    """The pack's catalogue at `path`, or an empty one."""
    path = Path(path)
    if path.exists():
        return json.loads(path.read_text())
    return {"format": FORMAT, "objects": [], "shells": []}


def write(path, pack):
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(pack, indent=1) + "\n")


def object_entry(name, variant, recipe, seed, measured, out):
    """The catalogue entry of a variant whose GLB lies at `out`/mesh_path(name, variant)."""
    relative = mesh_path(name, variant)
    return {
        "class": name,
        "variant": variant,
        "source": recipe.source,
        "generator": f"{GENERATOR}: {recipe.describe()}",
        "seed": seed,
        "size": measured.size,
        "scale": measured.scale,
        "triangles": measured.triangles,
        "supports": measured.supports,
        "under": measured.under,
        "path": relative,
        "sha256": sha256(Path(out) / relative),
        "license": LICENSE,
    }


def with_class(pack, name, entries):
    """`pack` with the entries of class `name` replaced by `entries`, sorted by class and
    variant (the other classes' entries stay as they are)."""
    objects = [e for e in pack["objects"] if e["class"] != name] + list(entries)
    objects.sort(key=lambda e: (e["class"], e["variant"]))
    return {**pack, "objects": objects}


def shell_entry(texture, seed, out):
    """The catalogue entry of a room-shell texture (recipes.ShellTexture) baked with `seed`."""
    relative = f"shell/{texture.name}.jpg"
    return {
        "name": texture.name,
        "kind": texture.kind,
        "source": "infinigen material",
        "generator": f"{GENERATOR}: materials.{texture.module}.{texture.material}",
        "seed": seed,
        "tile": texture.tile,
        "path": relative,
        "sha256": sha256(Path(out) / relative),
        "license": LICENSE,
    }
