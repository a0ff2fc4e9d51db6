"""The asset forge: every class of the release's lexicon as real-looking, textured meshes.

For each class (tools/forge/recipes.py) it spawns seeded variants from Infinigen's factories
(or composes simple parts dressed in Infinigen's materials where Infinigen has no factory),
keeps those that fit the class's plausible size (scaling uniformly into it), turns each to the
SceneSmith object frame (up +z, front +y, bottom at z = 0, centred), decimates it to its
triangle budget, bakes its procedural materials to one base-colour texture (every shader's
base colour as emission, so metals and coatings keep their colour), measures the surfaces
other objects can rest on, and writes a GLB with an embedded JPEG. Room shells (floors and
walls) are baked as tileable textures. `assets/catalogue.json` lists everything, with the
SHA-256 of every file. `--sheets` also renders, per class, each variant's original
(Cycles, procedural materials) beside its baked GLB, from the front and from three quarters.

Run with the forge's own Python (tools/forge/install.sh):

    tools/forge/.venv-forge/bin/python tools/forge/forge.py --out assets [--classes chair,sofa] [--sheets DIR]
"""

import argparse
import hashlib
import importlib
import json
import logging
import math
import os
import struct
import sys
import time
import zlib
from pathlib import Path

# Infinigen's generated pictures (book covers, TV screens) depend on Python's string hashing:
# the forge always runs with it fixed, so the same seeds give byte-identical files.
if __name__ == "__main__" and os.environ.get("PYTHONHASHSEED") != "0":
    os.execve(sys.executable, [sys.executable, *sys.argv], {**os.environ, "PYTHONHASHSEED": "0"})

import bpy  # noqa: E402 (first of Blender's: bmesh and mathutils come with it)
import bmesh  # noqa: E402
import numpy as np
from mathutils import Matrix, Vector
from mathutils.bvhtree import BVHTree

sys.path.insert(0, str(Path(__file__).parent))
import recipes  # noqa: E402

GENERATOR = "infinigen 1.15.5, bpy 4.2.0"
LICENSE = "BSD-3-Clause (Infinigen, Princeton University)"
CATALOGUE_FORMAT = "osmab-assets/1"
SEEDS_PER_VARIANT = 6
MIN_CLEAR_HEIGHT = 0.05  # free height above a support something can stand in, metres  # seeds tried for a variant that fits
FRONTS = {"+y": 0.0, "-x": -90.0, "-y": 180.0, "+x": 90.0}  # degrees about z that turn a front to +y

log = logging.getLogger("forge")


def reset():
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.cycles.seed = 0


def mesh_objects():
    return [o for o in bpy.data.objects if o.type == "MESH"]


def realize_and_join(name):
    """Every object of the scene as one mesh: instances made real, modifiers applied."""
    in_scene = bpy.context.view_layer.objects
    for o in list(in_scene):
        if o.type == "EMPTY" and o.instance_type != "NONE":
            bpy.ops.object.select_all(action="DESELECT")
            o.select_set(True)
            bpy.context.view_layer.objects.active = o
            bpy.ops.object.duplicates_make_real()
    # Only what the scene shows: factories leave helper objects outside the view layer (a
    # cabinet's frame its geometry nodes instance), which the conversion bakes in anyway.
    convertible = [o for o in bpy.context.view_layer.objects if o.type in ("MESH", "CURVE", "SURFACE", "META", "FONT") and not o.hide_render]
    bpy.ops.object.select_all(action="DESELECT")
    for o in convertible:
        o.hide_set(False)
        o.hide_viewport = False
        o.select_set(True)
    if not convertible:
        raise RuntimeError("the factory made no geometry")
    bpy.context.view_layer.objects.active = convertible[0]
    bpy.ops.object.make_single_user(object=True, obdata=True, material=False)
    bpy.ops.object.convert(target="MESH")
    meshes = [o for o in bpy.context.selected_objects if o.type == "MESH" and len(o.data.polygons) > 0]
    for o in [o for o in bpy.data.objects if o not in meshes]:
        bpy.data.objects.remove(o, do_unlink=True)
    bpy.ops.object.select_all(action="DESELECT")
    for o in meshes:
        o.select_set(True)
    bpy.context.view_layer.objects.active = meshes[0]
    # Bake each object's transform and parent into its vertices, then join.
    bpy.ops.object.parent_clear(type="CLEAR_KEEP_TRANSFORM")
    bpy.ops.object.transform_apply(location=True, rotation=True, scale=True)
    if len(meshes) > 1:
        bpy.ops.object.join()
    obj = bpy.context.view_layer.objects.active
    obj.name = name
    return obj


def bounds(obj):
    co = np.array([v.co[:] for v in obj.data.vertices])
    return co.min(axis=0), co.max(axis=0)


def normalise(obj, front, size_range):
    """Turn the front to +y, stand the object at z = 0 centred in x and y, and scale it
    uniformly into `size_range`; returns the scale, or None when no uniform scale fits."""
    obj.data.transform(Matrix.Rotation(math.radians(FRONTS[front]), 4, "Z"))
    lo, hi = bounds(obj)
    obj.data.transform(Matrix.Translation(Vector((-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]))))
    dims = hi - lo
    lows = [r[0] / d for r, d in zip(size_range, dims)]
    highs = [r[1] / d for r, d in zip(size_range, dims)]
    s_lo, s_hi = max(lows), min(highs)
    if s_lo > s_hi * 1.15:  # needs a stretch beyond what a uniform scale can give
        return None
    scale = min(max(1.0, s_lo), s_hi) if s_lo <= s_hi else math.sqrt(s_lo * s_hi)
    obj.data.transform(Matrix.Scale(scale, 4))
    obj.data.update()
    return scale


def stand_centred(obj):
    """Stand the object on z = 0, centred in x and y."""
    lo, hi = bounds(obj)
    obj.data.transform(Matrix.Translation(Vector((-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]))))
    obj.data.update()


def decimate(obj, budget):
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    mod = obj.modifiers.new("triangulate", "TRIANGULATE")
    bpy.ops.object.modifier_apply(modifier=mod.name)
    # A collapse stops short of its ratio on meshes of many small islands: collapse again,
    # harder, until the budget holds (or three rounds have not got there).
    for _ in range(3):
        triangles = len(obj.data.polygons)
        if triangles <= budget:
            break
        mod = obj.modifiers.new("decimate", "DECIMATE")
        mod.decimate_type = "COLLAPSE"
        mod.ratio = 0.98 * budget / triangles
        mod.use_collapse_triangulate = True
        bpy.ops.object.modifier_apply(modifier=mod.name)
    return len(obj.data.polygons)


BSDFS = {
    "ShaderNodeBsdfPrincipled": "Base Color",  # or its emission colour, when a picture drives it
    "ShaderNodeBsdfDiffuse": "Color",
    "ShaderNodeBsdfGlossy": "Color",
    "ShaderNodeBsdfAnisotropic": "Color",
    "ShaderNodeBsdfGlass": "Color",
    "ShaderNodeBsdfTranslucent": "Color",
    "ShaderNodeBsdfRefraction": "Color",
    "ShaderNodeSubsurfaceScattering": "Color",
    "ShaderNodeBsdfSheen": "Color",
    "ShaderNodeBsdfToon": "Color",
    "ShaderNodeBsdfHairPrincipled": "Color",
    "ShaderNodeEmission": "Color",
}


def albedo_as_emission(material):
    """Every BSDF of `material` replaced by an emission of its base colour, so an EMIT bake
    records the albedo (a metal's or a coating's too, which a diffuse bake loses)."""
    tree = material.node_tree
    _albedo_tree_as_emission(tree)
    output = next((n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial" and n.is_active_output), None)
    if output is not None:
        for link in list(output.inputs["Displacement"].links):
            tree.links.remove(link)


def _albedo_tree_as_emission(tree):
    """The same inside `tree` and every node group it uses (Infinigen's materials keep their
    BSDFs in groups; each group is copied first, so other materials keep theirs)."""
    for node in list(tree.nodes):
        if node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None:
            node.node_tree = node.node_tree.copy()
            _albedo_tree_as_emission(node.node_tree)
            continue
        socket_name = BSDFS.get(node.bl_idname)
        if socket_name is None:
            if node.bl_idname in ("ShaderNodeBsdfTransparent", "ShaderNodeHoldout", "ShaderNodeVolumePrincipled", "ShaderNodeVolumeAbsorption", "ShaderNodeVolumeScatter"):
                replacement = tree.nodes.new("ShaderNodeEmission")
                replacement.inputs["Color"].default_value = (0.5, 0.5, 0.5, 1.0)
                for link in list(tree.links):
                    if link.from_node == node:
                        tree.links.new(replacement.outputs[0], link.to_socket)
                tree.nodes.remove(node)
            continue
        source = node.inputs[socket_name]
        if node.bl_idname == "ShaderNodeBsdfPrincipled" and node.inputs["Emission Color"].is_linked:
            source = node.inputs["Emission Color"]  # a screen: its picture is what it shows
        emission = tree.nodes.new("ShaderNodeEmission")
        emission.inputs["Strength"].default_value = 1.0
        if source.is_linked:
            tree.links.new(source.links[0].from_socket, emission.inputs["Color"])
        else:
            emission.inputs["Color"].default_value = source.default_value
        for link in list(tree.links):
            if link.from_node == node:
                tree.links.new(emission.outputs[0], link.to_socket)
        tree.nodes.remove(node)


def dress_material(obj, module, cls, seed=None):
    """Infinigen's material `materials.<module>.<cls>` on `obj` (drawn from numpy's global
    generator, seeded with `seed` when given). Infinigen 1.15.5's materials come in two kinds:
    those that apply themselves to an object (and may add geometry nodes), and those that
    generate a material to assign."""
    if seed is not None:
        np.random.seed(seed)
    maker = getattr(importlib.import_module(f"infinigen.assets.materials.{module}"), cls)()
    if hasattr(maker, "apply"):
        maker.apply(obj)
        return
    material = maker.generate()
    obj.data.materials.clear()
    obj.data.materials.append(material)


def bake(obj, size, name, unwrap=True):
    """One base-colour texture of `size`² for `obj` (smart UV projection unless it has its
    UVs), which then carries it as its only material."""
    bpy.context.view_layer.objects.active = obj
    obj.select_set(True)
    uv_layers = obj.data.uv_layers
    if unwrap:
        # The factory's own UV maps stay what its materials read (a TV's picture, a book's
        # cover); the new map, active for editing and baking, is the one the GLB keeps.
        shading = uv_layers.active
        if shading is not None:
            shading.active_render = True
        target_uv = uv_layers.new(name="baked")
        uv_layers.active = target_uv
        bpy.ops.object.mode_set(mode="EDIT")
        bpy.ops.mesh.select_all(action="SELECT")
        bpy.ops.uv.smart_project(angle_limit=math.radians(66), island_margin=0.004, area_weight=0.0, scale_to_bounds=True)
        bpy.ops.object.mode_set(mode="OBJECT")
    image = bpy.data.images.new(f"{name}_albedo", size, size, alpha=False)
    image.colorspace_settings.name = "sRGB"
    if not obj.material_slots:
        fallback = bpy.data.materials.new("fallback")
        fallback.use_nodes = True
        obj.data.materials.append(fallback)
    for slot in obj.material_slots:
        if slot.material is None:
            slot.material = bpy.data.materials.new("empty")
        slot.material = slot.material.copy()
        material = slot.material
        material.use_nodes = True
        albedo_as_emission(material)
        target = material.node_tree.nodes.new("ShaderNodeTexImage")
        target.image = image
        material.node_tree.nodes.active = target
    scene = bpy.context.scene
    scene.cycles.bake_type = "EMIT"
    scene.render.bake.margin = 4
    bpy.ops.object.bake(type="EMIT")
    baked = bpy.data.materials.new(f"{name}_baked")
    baked.use_nodes = True
    bsdf = baked.node_tree.nodes["Principled BSDF"]
    texture = baked.node_tree.nodes.new("ShaderNodeTexImage")
    texture.image = image
    baked.node_tree.links.new(texture.outputs["Color"], bsdf.inputs["Base Color"])
    bsdf.inputs["Roughness"].default_value = 0.8
    bsdf.inputs["Metallic"].default_value = 0.0
    obj.data.materials.clear()
    obj.data.materials.append(baked)
    for layer in [layer for layer in uv_layers if layer != uv_layers.active]:
        uv_layers.remove(layer)
    if uv_layers.active is not None:
        uv_layers.active.active_render = True
    for polygon in obj.data.polygons:
        polygon.material_index = 0
    return image


def export_glb(obj, path):
    bpy.ops.object.select_all(action="DESELECT")
    obj.select_set(True)
    bpy.context.view_layer.objects.active = obj
    path.parent.mkdir(parents=True, exist_ok=True)
    bpy.ops.export_scene.gltf(
        filepath=str(path),
        export_format="GLB",
        use_selection=True,
        export_yup=True,
        export_apply=True,
        export_texcoords=True,
        export_normals=True,
        export_materials="EXPORT",
        export_image_format="JPEG",
        export_image_quality=88,
        export_cameras=False,
        export_lights=False,
        export_extras=False,
    )


def class_seed(name, variant, attempt):
    """The factory seed of a class's variant: classes sharing a factory (chair, dining
    chair) get variants of their own."""
    return (zlib.crc32(name.encode()) % 1000) * 100_000 + 1000 * (variant + 1) + attempt


def read_catalogue(path):
    """The pack's catalogue (dataset/src/assets/catalogue.rs), or an empty one."""
    if path.exists():
        return json.loads(path.read_text())
    return {"format": CATALOGUE_FORMAT, "objects": [], "shells": []}


def write_catalogue(path, pack):
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(json.dumps(pack, indent=1) + "\n")


def canonical_triangle_order(path):
    """Rewrite the triangle lists of the GLB at `path` in one canonical order (each triangle
    started at its smallest index, winding kept; triangles sorted): Blender's exporter lists
    the same triangles in an order that varies between runs. Returns how many triangles the
    GLB holds (the exporter drops degenerate ones, so it can be fewer than Blender counted)."""
    data = bytearray(path.read_bytes())
    json_length = struct.unpack_from("<I", data, 12)[0]
    gltf = json.loads(data[20 : 20 + json_length])
    binary = 20 + json_length + 8
    types = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32}
    triangles_total = 0
    for mesh in gltf["meshes"]:
        for primitive in mesh["primitives"]:
            if "indices" not in primitive or primitive.get("mode", 4) != 4:
                continue
            accessor = gltf["accessors"][primitive["indices"]]
            view = gltf["bufferViews"][accessor["bufferView"]]
            start = binary + view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
            dtype = np.dtype(types[accessor["componentType"]])
            count = accessor["count"]
            triangles = np.frombuffer(bytes(data[start : start + count * dtype.itemsize]), dtype=dtype).reshape(-1, 3)
            first = triangles.argmin(axis=1)
            rotated = np.stack([np.roll(t, -k) for t, k in zip(triangles, first)]) if len(triangles) else triangles
            ordered = rotated[np.lexsort(rotated.T[::-1])]
            triangles_total += len(ordered)
            data[start : start + count * dtype.itemsize] = ordered.astype(dtype).tobytes()
    path.write_bytes(bytes(data))
    return triangles_total


def sha256(path):
    return hashlib.sha256(Path(path).read_bytes()).hexdigest()


def supports_of(obj):
    """Surfaces other objects can rest on: upward faces grouped by height on a 1 cm grid;
    each region of at least 12 × 12 cm becomes its box, with the free height above it
    (`inside` when something of the object is above it) and whether it is open (seen and
    reached from the front: rays towards +y from above it leave the object)."""
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    bm.faces.ensure_lookup_table()
    bvh = BVHTree.FromBMesh(bm)
    cell = 0.01
    lo, hi = bounds(obj)
    levels = {}
    for face in bm.faces:
        if face.normal.z < 0.95 or face.calc_area() < 1e-6:
            continue
        z = sum(v.co.z for v in face.verts) / len(face.verts)
        if z < 0.05:
            continue
        key = round(z / 0.015)
        xs = [v.co.x for v in face.verts]
        ys = [v.co.y for v in face.verts]
        i0, i1 = int((min(xs) - lo[0]) / cell), int((max(xs) - lo[0]) / cell)
        j0, j1 = int((min(ys) - lo[1]) / cell), int((max(ys) - lo[1]) / cell)
        grid = levels.setdefault(key, {})
        for i in range(i0, i1 + 1):
            for j in range(j0, j1 + 1):
                p = Vector((lo[0] + (i + 0.5) * cell, lo[1] + (j + 0.5) * cell, z + 0.002))
                hit = bvh.ray_cast(p + Vector((0, 0, 0.01)), Vector((0, 0, -1)), 0.03)
                if hit[0] is not None and abs(hit[0].z - z) < 0.02:
                    grid[(i, j)] = max(grid.get((i, j), -1.0), hit[0].z)
    supports = []
    for key, grid in sorted(levels.items()):
        seen = set()
        for start in grid:
            if start in seen:
                continue
            stack, component = [start], []
            seen.add(start)
            while stack:
                c = stack.pop()
                component.append(c)
                for d in ((1, 0), (-1, 0), (0, 1), (0, -1)):
                    n = (c[0] + d[0], c[1] + d[1])
                    if n in grid and n not in seen:
                        seen.add(n)
                        stack.append(n)
            is_ = [c[0] for c in component]
            js = [c[1] for c in component]
            width, depth = (max(is_) - min(is_) + 1) * cell, (max(js) - min(js) + 1) * cell
            if width < 0.12 or depth < 0.12 or len(component) < 0.6 * (width / cell) * (depth / cell):
                continue
            height = float(np.median([grid[c] for c in component]))
            x0, x1 = lo[0] + min(is_) * cell, lo[0] + (max(is_) + 1) * cell
            y0, y1 = lo[1] + min(js) * cell, lo[1] + (max(js) + 1) * cell
            samples = [(x0 + (x1 - x0) * a, y0 + (y1 - y0) * b) for a in (0.2, 0.5, 0.8) for b in (0.2, 0.5, 0.8)]
            above = []
            escapes = 0
            for x, y in samples:
                hit = bvh.ray_cast(Vector((x, y, height + 0.005)), Vector((0, 0, 1)))
                above.append(hit[3] if hit[0] is not None else math.inf)
                front = bvh.ray_cast(Vector((x, y, height + 0.05)), Vector((0, 1, 0)), hi[1] - y + 0.05)
                escapes += front[0] is None
            clear = min(above)
            if clear < MIN_CLEAR_HEIGHT:
                continue  # a surface right under another one: nothing can rest on it
            supports.append(
                {
                    "height": round(height, 4),
                    "min": [round(x0, 4), round(y0, 4)],
                    "max": [round(x1, 4), round(y1, 4)],
                    "inside": math.isfinite(clear),
                    "open": escapes >= 0.6 * len(samples),
                    "clear_height": round(clear, 4) if math.isfinite(clear) else None,
                }
            )
    bm.free()
    return supports


def under_of(obj):
    """The floor under the object free up to a clearance (a table's, a desk's): rays up from
    the floor over the middle 80 % of its footprint; `None` when most hit below 0.2 m."""
    lo, hi = bounds(obj)
    bvh = BVHTree.FromObject(obj, bpy.context.evaluated_depsgraph_get())
    free = []
    for a in np.linspace(0.1, 0.9, 9):
        for b in np.linspace(0.1, 0.9, 9):
            x, y = lo[0] + (hi[0] - lo[0]) * a, lo[1] + (hi[1] - lo[1]) * b
            hit = bvh.ray_cast(Vector((x, y, 0.001)), Vector((0, 0, 1)))
            h = hit[3] if hit[0] is not None else math.inf
            free.append((x, y, h))
    tall = [f for f in free if f[2] >= 0.2]
    if len(tall) < 0.6 * len(free):
        return None
    clearance = min(f[2] for f in tall) - 0.02
    xs, ys = [f[0] for f in tall], [f[1] for f in tall]
    return {"clearance": round(min(clearance, float(hi[2])), 4), "min": [round(min(xs), 4), round(min(ys), 4)], "max": [round(max(xs), 4), round(max(ys), 4)]}


def spawn(recipe, seed, size_range, front):
    """The factory's asset for `seed`. A recipe `(module, factory, options)` passes its options
    to the factory; `sized` draws the asset's dimensions from the class's size range (in
    the factory's own axes: a factory facing +x has its depth along x), for factories whose
    own ranges miss the class (cabinets, wardrobes, counters)."""
    module, factory, options = (*recipe, {})[:3]
    options = dict(options)
    if options.pop("sized", False):
        width, depth, height = (float(np.random.uniform(lo, hi)) for lo, hi in size_range)
        options["dimensions"] = Vector((depth, width, height) if front == "+x" else (width, depth, height))
    cls = getattr(importlib.import_module(f"infinigen.assets.objects.{module}"), factory)
    return cls(factory_seed=seed, **options).spawn_asset(0)


def compose(name, seed):
    """Classes Infinigen has no factory for: simple parts in Infinigen's materials."""
    from composed import build  # noqa: PLC0415 (Blender must be loaded first)

    build(name, seed)


def shot(obj, path, view):
    """A 256 × 256 Cycles picture of `obj` from the front (`front`) or three quarters
    (`three_quarters`), lit by a sun and a grey sky: for the contact sheets."""
    scene = bpy.context.scene
    lo, hi = bounds(obj)
    centre = Vector(((lo + hi) / 2).tolist())
    radius = float(np.linalg.norm(hi - lo)) / 2
    direction = Vector((0.0, 1.0, 0.35) if view == "front" else (0.75, 1.0, 0.55)).normalized()
    camera_data = bpy.data.cameras.new("shot")
    camera_data.lens = 50
    camera = bpy.data.objects.new("shot", camera_data)
    scene.collection.objects.link(camera)
    camera.location = centre + direction * radius * 3.2
    camera.rotation_euler = (centre - camera.location).to_track_quat("-Z", "Y").to_euler()
    sun_data = bpy.data.lights.new("sun", "SUN")
    sun_data.energy = 3.0
    sun = bpy.data.objects.new("sun", sun_data)
    sun.rotation_euler = (math.radians(40), 0, math.radians(30))
    scene.collection.objects.link(sun)
    world = bpy.data.worlds.new("grey")
    world.use_nodes = True
    world.node_tree.nodes["Background"].inputs["Color"].default_value = (0.6, 0.6, 0.62, 1)
    world.node_tree.nodes["Background"].inputs["Strength"].default_value = 0.8
    scene.world = world
    scene.camera = camera
    scene.render.resolution_x = scene.render.resolution_y = 256
    scene.render.film_transparent = False
    scene.cycles.samples = 16
    scene.render.image_settings.file_format = "PNG"
    scene.render.filepath = str(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    bpy.ops.render.render(write_still=True)
    scene.cycles.samples = 1
    for o in (camera, sun):
        bpy.data.objects.remove(o, do_unlink=True)


def forge_variant(name, recipe, seed, size_range, budget, texture, out_dir, front, shots=None):
    reset()
    np.random.seed(seed)
    if recipe == "composed":
        compose(name, seed)
    else:
        spawn(recipe, seed, size_range, front)
    obj = realize_and_join(name.replace(" ", "_"))
    scale = normalise(obj, front, size_range)
    if scale is None:
        return None
    if shots is not None:
        shot(obj, shots / "original.png", "three_quarters")
    triangles = decimate(obj, budget)
    stand_centred(obj)  # decimation may move the extreme vertices
    if triangles > 1.5 * budget:
        # Thousands of small islands (a woven seat) that collapsing cannot merge: another seed.
        log.info("%s seed %d: %d triangles after decimation, over 1.5 × the budget of %d", name, seed, triangles, budget)
        return None
    bake(obj, texture, name.replace(" ", "_"))
    if shots is not None:
        shot(obj, shots / "baked.png", "three_quarters")
        shot(obj, shots / "front.png", "front")
    lo, hi = bounds(obj)
    record = {
        "size": [round(float(v), 4) for v in hi - lo],
        "scale": round(scale, 4),
        "triangles": triangles,
        "supports": supports_of(obj),
        "under": under_of(obj),
    }
    return obj, record


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", required=True, help="the asset pack folder (assets/)")
    parser.add_argument("--classes", help="comma-separated classes (default: every class of the recipes)")
    parser.add_argument("--variants", type=int, default=recipes.VARIANTS)
    parser.add_argument("--sheets", help="write a contact sheet per class here")
    parser.add_argument("--no-shell", action="store_true", help="skip the room-shell textures")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    for noisy in ("infinigen", "bpy"):
        logging.getLogger(noisy).setLevel(logging.WARNING)
    out = Path(args.out)
    catalogue_path = out / "catalogue.json"
    pack = read_catalogue(catalogue_path)
    catalogue = pack["objects"]
    wanted = args.classes.split(",") if args.classes else list(recipes.RECIPES)
    started = time.time()
    for name in wanted:
        factories, size_range, furniture = recipes.RECIPES[name]
        budget = recipes.FURNITURE_TRIANGLES if furniture else recipes.SMALL_TRIANGLES
        texture = 512 if furniture else 256
        catalogue = [e for e in catalogue if e["class"] != name]
        slug = name.replace(" ", "-")
        made = 0
        for variant in range(args.variants):
            recipe = factories[variant % len(factories)]
            front = recipes.front_of(recipe)
            for attempt in range(SEEDS_PER_VARIANT):
                seed = class_seed(name, variant, attempt)
                clock = time.time()
                shots = Path(args.sheets) / "shots" / f"{slug}-{variant}" if args.sheets else None
                try:
                    made_variant = forge_variant(name, recipe, seed, size_range, budget, texture, out, front, shots)
                except Exception as e:  # a factory that fails for a seed: the next seed
                    log.warning("%s variant %d seed %d: %s", name, variant, seed, e)
                    continue
                if made_variant is None:
                    log.info("%s variant %d seed %d: does not fit %s", name, variant, seed, size_range)
                    continue
                obj, record = made_variant
                path = out / "meshes" / f"{slug}-{variant}.glb"
                export_glb(obj, path)
                record["triangles"] = canonical_triangle_order(path)
                source = "infinigen" if recipe != "composed" else "composed (infinigen materials)"
                generator = f"{GENERATOR}: " + recipes.describe(recipe)
                catalogue.append(
                    {
                        "class": name,
                        "variant": variant,
                        "source": source,
                        "generator": generator,
                        "seed": seed,
                        **record,
                        "path": f"meshes/{slug}-{variant}.glb",
                        "sha256": sha256(path),
                        "license": LICENSE,
                    }
                )
                log.info("%s variant %d: seed %d, %s, %d triangles, %.1f s", name, variant, seed, record["size"], record["triangles"], time.time() - clock)
                made += 1
                break
        if made == 0:
            log.error("%s: no variant fits; the class keeps the synthesizer's procedural asset", name)
        catalogue.sort(key=lambda e: (e["class"], e["variant"]))
        pack["objects"] = catalogue
        write_catalogue(catalogue_path, pack)
    if not args.no_shell:
        import shell  # noqa: PLC0415

        shell.forge_shell(out)
    if args.sheets:
        import sheets  # noqa: PLC0415

        sheets.write(out, Path(args.sheets), wanted)
    log.info("forged %s in %.0f s", ", ".join(wanted), time.time() - started)
    logging.shutdown()
    os._exit(0)  # bpy can crash while the interpreter tears it down; everything is written


if __name__ == "__main__":
    main()
