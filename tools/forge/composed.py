"""Classes Infinigen has no factory for, composed of simple parts (bevelled boxes, cylinders,
spheres) and dressed in Infinigen's procedural materials, so they bake to textures like the
rest of the pack. Every part is made in the object frame: x right, y front, z up, standing on
z = 0; sizes vary with the seed within the class's range (drawn from the generator each
builder is given)."""

import math

import bpy
import numpy as np

from blender import dress_material as dress  # Infinigen's materials.<module>.<cls> on a part


def box(name, center, size, bevel=0.01):
    bpy.ops.mesh.primitive_cube_add(size=1, location=center)
    obj = bpy.context.active_object
    obj.name = name
    obj.scale = size
    bpy.ops.object.transform_apply(scale=True)
    if bevel > 0:
        mod = obj.modifiers.new("bevel", "BEVEL")
        mod.width = bevel
        mod.segments = 3
    return obj


def cylinder(name, center, radius, depth, vertices=32, radius2=None):
    if radius2 is None:
        bpy.ops.mesh.primitive_cylinder_add(vertices=vertices, radius=radius, depth=depth, location=center)
    else:
        bpy.ops.mesh.primitive_cone_add(vertices=vertices, radius1=radius, radius2=radius2, depth=depth, location=center)
    obj = bpy.context.active_object
    obj.name = name
    return obj


def bench(rng):
    w, d, h = rng.uniform(1.0, 1.5), rng.uniform(0.35, 0.45), rng.uniform(0.43, 0.47)
    seat = box("seat", (0, 0, h - 0.025), (w, d, 0.05), 0.008)
    legs = [box(f"leg{i}", (sx * (w / 2 - 0.06), 0, (h - 0.05) / 2), (0.05, d - 0.04, h - 0.05), 0.005) for i, sx in enumerate((-1, 1))]
    rail = box("rail", (0, 0, 0.12), (w - 0.12, 0.04, 0.04), 0.004)
    dress(seat, "wood", "Wood")
    for part in [*legs, rail]:
        dress(part, "wood", "Wood") if rng.uniform() < 0.5 else dress(part, "metal", "BrushedMetal")


def laptop(rng):
    w, d = rng.uniform(0.32, 0.36), rng.uniform(0.23, 0.25)
    base = box("base", (0, 0, 0.009), (w, d, 0.018), 0.004)
    keys = box("keys", (0, 0.02, 0.0185), (w - 0.04, d * 0.45, 0.002), 0.0)
    lid = box("lid", (0, -d / 2 + 0.006, 0.115), (w, 0.008, d * 0.95), 0.003)
    screen = box("screen", (0, -d / 2 + 0.0115, 0.118), (w - 0.03, 0.002, d * 0.8), 0.0)
    lid.rotation_euler.x = math.radians(-12)
    screen.rotation_euler.x = math.radians(-12)
    dress(base, "metal", "Aluminum")
    dress(lid, "metal", "Aluminum")
    dress(keys, "plastic", "BlackPlastic")
    dress(screen, "metal", "BlackGlass")


def backpack(rng):
    w, d, h = rng.uniform(0.28, 0.34), rng.uniform(0.18, 0.24), rng.uniform(0.4, 0.48)
    body = box("body", (0, 0, h / 2), (w, d, h), 0.06)
    pocket = box("pocket", (0, d / 2 + 0.02, h * 0.3), (w * 0.8, 0.05, h * 0.35), 0.03)
    for i, sx in enumerate((-1, 1)):
        strap = box(f"strap{i}", (sx * w * 0.25, -d / 2 - 0.01, h * 0.55), (0.05, 0.02, h * 0.8), 0.008)
        dress(strap, "fabric", "LinedFabric")
    dress(body, "fabric", "CoarseKnitFabric")
    dress(pocket, "fabric", "CoarseKnitFabric")


def suitcase(rng):
    w, d, h = rng.uniform(0.38, 0.46), rng.uniform(0.22, 0.28), rng.uniform(0.62, 0.68)
    shell = box("shell", (0, 0, h / 2 + 0.03), (w, d, h), 0.03)
    handle = box("handle", (0, 0, h + 0.06), (0.15, 0.03, 0.03), 0.008)
    for i, sx in enumerate((-1, 1)):
        wheel = cylinder(f"wheel{i}", (sx * (w / 2 - 0.04), -d / 2 + 0.04, 0.025), 0.025, 0.02)
        wheel.rotation_euler.y = math.pi / 2
        dress(wheel, "plastic", "BlackPlastic")
    dress(shell, "plastic", "PlasticRough")
    dress(handle, "plastic", "BlackPlastic")


def helmet(rng):
    r = rng.uniform(0.11, 0.13)
    bpy.ops.mesh.primitive_uv_sphere_add(radius=r, location=(0, 0, 0), segments=32, ring_count=16)
    dome = bpy.context.active_object
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.select_all(action="DESELECT")
    bpy.ops.object.mode_set(mode="OBJECT")
    for v in dome.data.vertices:
        v.select = v.co.z < 0
    bpy.ops.object.mode_set(mode="EDIT")
    bpy.ops.mesh.delete(type="VERT")
    bpy.ops.object.mode_set(mode="OBJECT")
    dome.scale = (1.0, 1.15, 1.3)
    brim = cylinder("brim", (0, 0.02, 0.005), r * 1.1, 0.01)
    brim.scale = (1.0, 1.3, 1.0)
    dress(dome, "plastic", "Plastic")
    dress(brim, "plastic", "Plastic")


def clock(rng):
    r = rng.uniform(0.09, 0.12)
    body = cylinder("body", (0, 0, r), r, 0.05, 48)
    body.rotation_euler.x = math.pi / 2
    face = cylinder("face", (0, 0.026, r), r * 0.88, 0.004, 48)
    face.rotation_euler.x = math.pi / 2
    hour = box("hour", (0, 0.03, r + r * 0.2), (0.008, 0.002, r * 0.45), 0.0)
    minute = box("minute", (r * 0.25, 0.031, r), (r * 0.6, 0.002, 0.006), 0.0)
    dress(body, "wood", "Wood")
    dress(face, "ceramic", "Ceramic")
    dress(hour, "plastic", "BlackPlastic")
    dress(minute, "plastic", "BlackPlastic")


def printer(rng):
    w, d, h = rng.uniform(0.4, 0.5), rng.uniform(0.35, 0.42), rng.uniform(0.2, 0.28)
    body = box("body", (0, 0, h / 2), (w, d, h), 0.02)
    tray = box("tray", (0, d / 2 + 0.06, 0.05), (w * 0.7, 0.14, 0.01), 0.002)
    slot = box("slot", (0, d / 2 - 0.005, h * 0.55), (w * 0.75, 0.012, 0.02), 0.0)
    panel = box("panel", (w * 0.3, d / 2 - 0.06, h + 0.005), (w * 0.25, 0.08, 0.01), 0.002)
    dress(body, "plastic", "Plastic")
    dress(tray, "plastic", "Plastic")
    dress(slot, "plastic", "BlackPlastic")
    dress(panel, "plastic", "BlackPlastic")


def bucket(rng):
    r, h = rng.uniform(0.12, 0.15), rng.uniform(0.26, 0.34)
    pail = cylinder("pail", (0, 0, h / 2), r * 0.8, h, 40, radius2=r)
    handle = bpy.ops.mesh.primitive_torus_add(major_radius=r, minor_radius=0.005, location=(0, 0, h))
    arc = bpy.context.active_object
    arc.rotation_euler.x = math.pi / 2
    dress(pail, "metal", "GalvanizedMetal")
    dress(arc, "metal", "MetalBasic")
    return handle


BUILDERS = {
    "bench": bench,
    "laptop": laptop,
    "backpack": backpack,
    "suitcase": suitcase,
    "helmet": helmet,
    "clock": clock,
    "printer": printer,
    "bucket": bucket,
}


def build(name, seed):
    """Builder `name`'s parts for `seed`: their sizes from a generator of their own; their
    materials from Infinigen's (seeded by blender.seed_infinigen before the build)."""
    BUILDERS[name](np.random.default_rng(seed))
