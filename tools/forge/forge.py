"""The asset forge: every class of the release's lexicon as real-looking, textured meshes.

For each class of the class table (dataset/classes.toml, read by recipes.py) it spawns
seeded variants from Infinigen's factories (or composes simple parts dressed in Infinigen's
materials where Infinigen has no factory), keeps those that fit the class's plausible size
(scaling uniformly into it, or a thin axis on its own), turns each to the
SceneSmith object frame (up +z, front +y, bottom at z = 0, centred), decimates it to its
triangle budget, bakes its procedural materials to one base-colour texture (every shader's
base colour as emission, so metals and coatings keep their colour), measures the surfaces
other objects can rest on, and writes a GLB with an embedded JPEG. Room shells (floors and
walls) are baked as tileable textures. `assets/catalogue.json` lists everything, with the
SHA-256 of every file. `--sheets` also renders, per class, each variant's original
(Cycles, procedural materials) beside its baked GLB, from the front and from three quarters.
`--occlusion` bakes ambient occlusion into the pack's GLBs (their glTF occlusionTexture)
without forging them again; forging ends with it for the classes forged.

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
import glb  # noqa: E402
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
    # Nor what a factory keeps in a hidden collection (a door's parts, which its geometry
    # nodes join into the one object it shows).
    convertible = [o for o in bpy.context.view_layer.objects if o.type in ("MESH", "CURVE", "SURFACE", "META", "FONT") and not o.hide_render and not all(c.hide_render or c.hide_viewport for c in o.users_collection)]
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


def fit(dims, size_range, stretch=False):
    """The scale (x, y, z) that brings an object of `dims` into `size_range`: uniform, the
    smallest change that fits (up to 15 % short of the range where nothing fits exactly, the
    geometric mean then); with `stretch`, where no uniform scale fits, the thinnest axis is
    scaled on its own (a rug's thickness, a picture's depth) and the other two uniformly.
    None when nothing fits."""
    lows = [r[0] / d for r, d in zip(size_range, dims)]
    highs = [r[1] / d for r, d in zip(size_range, dims)]

    def uniform(axes):
        s_lo, s_hi = max(lows[a] for a in axes), min(highs[a] for a in axes)
        if s_lo > s_hi * 1.15:  # needs a stretch beyond what a uniform scale can give
            return None
        return min(max(1.0, s_lo), s_hi) if s_lo <= s_hi else math.sqrt(s_lo * s_hi)

    every = (0, 1, 2)
    if not stretch or max(lows) <= min(highs):
        scale = uniform(every)
        return None if scale is None else (scale, scale, scale)
    thin = int(np.argmin(dims))
    scale = uniform([a for a in every if a != thin])
    if scale is None:
        return None
    scales = [scale] * 3
    scales[thin] = min(max(scale, lows[thin]), highs[thin])
    return tuple(scales)


def cut_behind_back(obj):
    """For things hung on a wall (a door, a window, a picture): everything behind its back
    plane cut away (a door's handle on the far side), so its back (-y) lies flat at the wall.
    The back plane is the rearmost one, among the faces looking back or front (Infinigen
    winds faces either way), that covers at least 5 % of the object's front view (a handle's
    rosette does not)."""
    bm = bmesh.new()
    bm.from_mesh(obj.data)
    lo, hi = bounds(obj)
    view = (hi[0] - lo[0]) * (hi[2] - lo[2])
    planes = {}
    for face in bm.faces:
        if abs(face.normal.y) > 0.95:
            y = round(face.calc_center_median().y, 3)
            planes[y] = planes.get(y, 0.0) + face.calc_area()
    backs = sorted(y for y, area in planes.items() if area >= 0.05 * view)
    if backs and backs[0] > lo[1] + 1e-4:
        geom = bm.verts[:] + bm.edges[:] + bm.faces[:]
        bmesh.ops.bisect_plane(bm, geom=geom, dist=1e-5, plane_co=(0.0, backs[0] - 1e-4, 0.0), plane_no=(0.0, 1.0, 0.0), clear_inner=True)
        bm.to_mesh(obj.data)
        obj.data.update()
    bm.free()


def normalise(obj, front, size_range, stretch=False, flat_back=False):
    """Turn the front to +y (cutting away what is behind the back plane when `flat_back`),
    stand the object at z = 0 centred in x and y, and scale it into `size_range` (fit());
    returns the uniform scale (of the two other axes where the thin one was stretched), or
    None when no scale fits."""
    obj.data.transform(Matrix.Rotation(math.radians(FRONTS[front]), 4, "Z"))
    if flat_back:
        cut_behind_back(obj)
    lo, hi = bounds(obj)
    obj.data.transform(Matrix.Translation(Vector((-(lo[0] + hi[0]) / 2, -(lo[1] + hi[1]) / 2, -lo[2]))))
    dims = hi - lo
    scales = fit(dims, size_range, stretch)
    if scales is None:
        return None
    if scales[0] == scales[1] == scales[2]:
        obj.data.transform(Matrix.Scale(scales[0], 4))
    else:
        obj.data.transform(Matrix.Diagonal((*scales, 1.0)))
    obj.data.update()
    return scales[(int(np.argmin(dims)) + 1) % 3]


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


# A window's or a glazed door's glass, baked as what it shows from inside a room by day: a
# light, slightly blue-grey pane (sRGB; the synthesizer draws it opaque in front of a wall).
# Infinigen's glass is transparent, which an emission bake records as a dark grey.
GLASS_PANE = (0.80, 0.85, 0.89)
GLASS_NODES = ("ShaderNodeBsdfTransparent", "ShaderNodeBsdfGlass", "ShaderNodeBsdfRefraction")


def is_glass(tree):
    """Whether a material's node tree (or a node group it uses) is glass: a transparent, glass
    or refraction BSDF, or a principled BSDF that mostly transmits."""
    for node in tree.nodes:
        if node.bl_idname in GLASS_NODES:
            return True
        if node.bl_idname == "ShaderNodeBsdfPrincipled":
            transmission = node.inputs.get("Transmission Weight")
            if transmission is not None and not transmission.is_linked and transmission.default_value >= 0.5:
                return True
        if node.bl_idname == "ShaderNodeGroup" and node.node_tree is not None and is_glass(node.node_tree):
            return True
    return False


def as_pane(material):
    """The material's surface replaced by an emission of GLASS_PANE."""
    tree = material.node_tree
    output = next((n for n in tree.nodes if n.bl_idname == "ShaderNodeOutputMaterial" and n.is_active_output), None)
    if output is None:
        output = tree.nodes.new("ShaderNodeOutputMaterial")
    for socket in ("Surface", "Displacement", "Volume"):
        for link in list(output.inputs[socket].links):
            tree.links.remove(link)
    emission = tree.nodes.new("ShaderNodeEmission")
    emission.inputs["Color"].default_value = (*(srgb_to_linear(c) for c in GLASS_PANE), 1.0)
    emission.inputs["Strength"].default_value = 1.0
    tree.links.new(emission.outputs[0], output.inputs["Surface"])


def srgb_to_linear(c):
    return c / 12.92 if c <= 0.04045 else ((c + 0.055) / 1.055) ** 2.4


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


# A texel spanning more of the object than this (a rug's, 2.4 m on a 256² texture) is baked
# from 16 samples spread over it: one sample a texel aliases a fine weave into stripes.
# Everything smaller keeps one sample a texel, as the committed pack was baked.
SUPERSAMPLED_TEXEL = 0.008  # metres


def bake(obj, size, name, unwrap=True, panes=False):
    """One base-colour texture of `size`² for `obj` (smart UV projection unless it has its
    UVs), which then carries it as its only material. With `panes` (doors and windows), glass
    bakes as GLASS_PANE."""
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
        if panes and is_glass(material.node_tree):
            as_pane(material)
        else:
            albedo_as_emission(material)
        target = material.node_tree.nodes.new("ShaderNodeTexImage")
        target.image = image
        material.node_tree.nodes.active = target
    scene = bpy.context.scene
    scene.cycles.bake_type = "EMIT"
    scene.render.bake.margin = 4
    lo, hi = bounds(obj)
    scene.cycles.samples = 16 if unwrap and float((hi - lo).max()) / size > SUPERSAMPLED_TEXEL else 1
    bpy.ops.object.bake(type="EMIT")
    scene.cycles.samples = 1
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
    """Rewrite the GLB at `path` with its triangle lists in one canonical order (glb.py);
    returns how many triangles it holds (the exporter drops degenerate ones, so it can be
    fewer than Blender counted)."""
    data, triangles = glb.canonical_triangle_order(path.read_bytes())
    path.write_bytes(data)
    return triangles


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


# Factories that take their dimensions when the asset is made (create_asset, not the
# constructor), and the order they take them in from the class's (width, depth, height).
DIMENSIONS_AT_CREATION = {
    "WindowFactory": lambda width, depth, height: (width, height, depth),  # frame thickness last
}


def spawn(recipe, seed, size_range):
    """The factory's asset for `seed`, the recipe's options passed to the factory. A `sized`
    recipe draws the asset's dimensions from the class's size range (in the factory's own
    axes: a factory facing +x has its depth along x), for factories whose own ranges miss the
    class (cabinets, wardrobes, counters, windows)."""
    options = dict(recipe.options)
    made = {}
    if recipe.sized:
        width, depth, height = (float(np.random.uniform(lo, hi)) for lo, hi in size_range)
        if recipe.factory_class in DIMENSIONS_AT_CREATION:
            made["dimensions"] = DIMENSIONS_AT_CREATION[recipe.factory_class](width, depth, height)
        else:
            options["dimensions"] = Vector((depth, width, height) if recipe.front == "+x" else (width, depth, height))
    module = importlib.import_module(f"infinigen.assets.objects.{recipe.factory_module}")
    cls = getattr(module, recipe.factory_class)
    return cls(factory_seed=seed, **options).spawn_asset(0, **made)


def composed_builders():
    """The builders composed.py has (it needs Blender: imported here, not by recipes.py)."""
    from composed import BUILDERS  # noqa: PLC0415

    return set(BUILDERS)


def compose(builder, seed):
    """Classes Infinigen has no factory for: simple parts in Infinigen's materials."""
    from composed import build  # noqa: PLC0415 (Blender must be loaded first)

    build(builder, seed)


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


def forge_variant(kind, recipe, seed, out_dir, shots=None):
    """One variant of the class `kind` (recipes.ForgeClass) from `recipe` and `seed`: the
    object and its catalogue record, or None when it does not fit."""
    name = kind.name
    reset()
    np.random.seed(seed)
    if recipe.is_composed:
        compose(recipe.composed, seed)
    else:
        spawn(recipe, seed, kind.size_range)
    obj = realize_and_join(name.replace(" ", "_"))
    scale = normalise(obj, recipe.front, kind.size_range, stretch=recipe.stretch, flat_back=kind.rests == "wall")
    if scale is None:
        return None
    budget, texture = kind.triangles, kind.texture
    if shots is not None:
        shot(obj, shots / "original.png", "three_quarters")
    triangles = decimate(obj, budget)
    stand_centred(obj)  # decimation may move the extreme vertices
    if triangles > 1.5 * budget:
        # Thousands of small islands (a woven seat) that collapsing cannot merge: another seed.
        log.info("%s seed %d: %d triangles after decimation, over 1.5 × the budget of %d", name, seed, triangles, budget)
        return None
    bake(obj, texture, name.replace(" ", "_"), panes=kind.role == "shell")
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


# The occlusion pass (--occlusion): Cycles' ambient occlusion of each forged mesh, baked on
# its own texture atlas (TEXCOORD_0) and written into its GLB as the glTF occlusionTexture.
AO_SAMPLES = 24  # a full-resolution texel; 96 for each stored (half-resolution) one
AO_DISTANCE_FURNITURE = 0.5  # metres: furniture and the room's fixtures
AO_DISTANCE_SMALL = 0.2  # metres: small objects
AO_MARGIN = 2  # texels the bake extends past the UV islands (so filtering finds no white seam)
# The bake is made at the base-colour texture's resolution and stored at half of it (2 × 2
# texels averaged: less noise, a quarter of the bytes; occlusion has no fine detail).
AO_QUALITY = 85


def occlusion_bake(objects, size, distance, rests):
    """The ambient occlusion of `objects` (greyscale, `size`² floats in [0, 1], rows from the
    image's top as a file stores them) on their active UV map, smoothed over the islands and
    their margin (smooth()); texels no island nor its margin covers are white. Infinigen's
    meshes have faces wound either way and are drawn double-sided, so each face is baked from
    both sides and keeps the lighter one (the side seen from outside; a face buried in another
    part is dark from both). Furniture standing
    on the floor has the floor as an occluder (the underside of a seat, the foot of a
    cabinet), a door's, a window's or a picture's the wall behind it; small objects only
    themselves (they are moved from table to shelf)."""
    scene = bpy.context.scene
    scene.cycles.samples = AO_SAMPLES
    world = bpy.data.worlds.new("occlusion")
    world.light_settings.distance = distance
    scene.world = world
    lo = np.min([np.array(o.bound_box).min(axis=0) for o in objects], axis=0)
    if rests == "floor":
        bpy.ops.mesh.primitive_plane_add(size=50.0, location=(0.0, 0.0, float(lo[2])))
    elif rests == "wall":
        bpy.ops.mesh.primitive_plane_add(size=50.0, location=(0.0, float(lo[1]), 0.0), rotation=(math.pi / 2, 0.0, 0.0))
    uncovered = -1.0  # what the image holds where the bake writes nothing
    images = []
    for side in ("outside", "inside"):
        image = bpy.data.images.new(f"occlusion_{side}", size, size, alpha=False, float_buffer=True)
        image.colorspace_settings.name = "Non-Color"
        image.pixels[:] = np.full(size * size * 4, uncovered, dtype=np.float32)
        for obj in objects:
            for material in obj.data.materials:
                material.use_nodes = True
                node = material.node_tree.nodes.new("ShaderNodeTexImage")
                node.image = image
                material.node_tree.nodes.active = node
        bpy.ops.object.select_all(action="DESELECT")
        for obj in objects:
            obj.select_set(True)
            bpy.context.view_layer.objects.active = obj
            if side == "inside":
                bpy.ops.object.mode_set(mode="EDIT")
                bpy.ops.mesh.select_all(action="SELECT")
                bpy.ops.mesh.flip_normals()
                bpy.ops.object.mode_set(mode="OBJECT")
            elif obj.data.has_custom_normals:
                bpy.ops.mesh.customdata_custom_splitnormals_clear()
        for obj in objects:
            obj.select_set(True)
        scene.render.bake.margin = AO_MARGIN
        scene.render.bake.use_clear = False
        scene.render.bake.use_selected_to_active = False
        bpy.ops.object.bake(type="AO")
        images.append(np.array(image.pixels[:], dtype=np.float32).reshape(size, size, 4)[..., 0])
    covered = (images[0] > uncovered / 2) & (images[1] > uncovered / 2)
    ao = smooth(np.clip(np.maximum(*images), 0.0, 1.0), covered)
    return np.where(covered, ao, 1.0)[::-1]


def smooth(image, covered):
    """`image` blurred (3 × 3, weights 1 2 1) over the `covered` texels only, so the bake's
    noise goes and nothing outside the islands (and their margin) bleeds in."""
    weights = np.array([1.0, 2.0, 1.0])
    padded = np.pad(np.where(covered, image, 0.0), 1)
    mask = np.pad(covered.astype(np.float64), 1)
    total = np.zeros(image.shape)
    weight = np.zeros(image.shape)
    n, m = image.shape
    for i in range(3):
        for j in range(3):
            w = weights[i] * weights[j]
            total += w * padded[i : i + n, j : j + m]
            weight += w * mask[i : i + n, j : j + m]
    return np.where(covered, total / np.maximum(weight, 1e-9), image)


def half(image):
    """`image` (n × n) at half its resolution, each texel the mean of 2 × 2."""
    n = image.shape[0] // 2
    return image[: 2 * n, : 2 * n].reshape(n, 2, n, 2).mean(axis=(1, 3))


def occlusion_jpeg(ao):
    """The occlusion as a JPEG (grey in all three channels; glTF reads the red one)."""
    from io import BytesIO  # noqa: PLC0415

    from PIL import Image  # noqa: PLC0415

    grey = np.round(ao * 255.0).astype(np.uint8)
    buffer = BytesIO()
    Image.fromarray(grey, "L").convert("RGB").save(buffer, "JPEG", quality=AO_QUALITY)
    return buffer.getvalue()


def occlusion_pass(out, classes, dump=None):
    """Bake the occlusion of every catalogued mesh of `classes` (None: all) into its GLB (the
    geometry and the base-colour texture stay byte for byte); updates the catalogue's SHA-256."""
    import tempfile  # noqa: PLC0415

    catalogue_path = out / "catalogue.json"
    pack = read_catalogue(catalogue_path)
    for entry in pack["objects"]:
        if classes is not None and entry["class"] not in classes:
            continue
        clock = time.time()
        path = out / entry["path"]
        data = glb.strip_occlusion(path.read_bytes())
        gltf, binary = glb.read(data)
        size = glb.jpeg_size(glb.image_bytes(gltf, binary, glb.base_colour_image(gltf)))[0]
        kind = recipes.RECIPES.get(entry["class"])
        furniture = kind.furniture if kind is not None else size >= recipes.FURNITURE_TEXTURE
        distance = AO_DISTANCE_FURNITURE if furniture else AO_DISTANCE_SMALL
        reset()
        with tempfile.TemporaryDirectory() as tmp:
            source = Path(tmp) / "mesh.glb"
            source.write_bytes(data)
            bpy.ops.import_scene.gltf(filepath=str(source))
        objects = [o for o in bpy.context.view_layer.objects if o.type == "MESH"]
        ao = half(occlusion_bake(objects, size, distance, kind.rests if kind is not None else "surface"))
        name = gltf["images"][glb.base_colour_image(gltf)].get("name", entry["class"]).removesuffix("_albedo")
        path.write_bytes(glb.embed_occlusion(data, occlusion_jpeg(ao), name))
        entry["sha256"] = sha256(path)
        if dump is not None:
            from PIL import Image  # noqa: PLC0415

            dump.mkdir(parents=True, exist_ok=True)
            Image.fromarray(np.round(ao * 255.0).astype(np.uint8), "L").save(dump / f"{Path(entry['path']).stem}.png")
        log.info("%s: occlusion %d² (distance %.1f m, mean %.2f, %.0f %% under 0.5) in %.1f s", entry["path"], ao.shape[0], distance, float(ao.mean()), 100.0 * float((ao < 0.5).mean()), time.time() - clock)
        write_catalogue(catalogue_path, pack)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", required=True, help="the asset pack folder (assets/)")
    parser.add_argument("--classes", help="comma-separated classes (default: every class of the recipes)")
    parser.add_argument("--variants", type=int, default=recipes.VARIANTS)
    parser.add_argument("--sheets", help="write a contact sheet per class here")
    parser.add_argument("--no-shell", action="store_true", help="skip the room-shell textures")
    parser.add_argument("--occlusion", action="store_true", help="only bake ambient occlusion into the pack's meshes (no forging)")
    parser.add_argument("--no-occlusion", action="store_true", help="forge without baking the occlusion of what was forged")
    parser.add_argument("--dump-occlusion", help="also write each occlusion image here as PNG")
    args = parser.parse_args()
    logging.basicConfig(level=logging.INFO, format="%(asctime)s %(message)s")
    for noisy in ("infinigen", "bpy"):
        logging.getLogger(noisy).setLevel(logging.WARNING)
    out = Path(args.out)
    wanted = args.classes.split(",") if args.classes else list(recipes.RECIPES)
    unknown = [name for name in wanted if name not in recipes.RECIPES]
    if unknown:
        parser.error(f"no forge recipe for {', '.join(unknown)} in {recipes.TABLE}")
    started = time.time()
    if args.occlusion:
        occlusion_pass(out, set(wanted) if args.classes else None, Path(args.dump_occlusion) if args.dump_occlusion else None)
        log.info("occlusion baked in %.0f s", time.time() - started)
        logging.shutdown()
        os._exit(0)
    builders = composed_builders()
    missing = sorted({r.composed for name in wanted for r in recipes.RECIPES[name].recipes if r.is_composed} - builders)
    if missing:
        parser.error(f"composed.py has no builder {', '.join(missing)}")
    catalogue_path = out / "catalogue.json"
    pack = read_catalogue(catalogue_path)
    catalogue = pack["objects"]
    for name in wanted:
        kind = recipes.RECIPES[name]
        catalogue = [e for e in catalogue if e["class"] != name]
        slug = name.replace(" ", "-")
        made = 0
        for variant in range(args.variants):
            recipe = kind.recipes[variant % len(kind.recipes)]
            for attempt in range(SEEDS_PER_VARIANT):
                seed = class_seed(name, variant, attempt)
                clock = time.time()
                shots = Path(args.sheets) / "shots" / f"{slug}-{variant}" if args.sheets else None
                try:
                    made_variant = forge_variant(kind, recipe, seed, out, shots)
                except Exception as e:  # a factory that fails for a seed: the next seed
                    log.warning("%s variant %d seed %d: %s", name, variant, seed, e)
                    continue
                if made_variant is None:
                    log.info("%s variant %d seed %d: does not fit %s", name, variant, seed, kind.size_range)
                    continue
                obj, record = made_variant
                path = out / "meshes" / f"{slug}-{variant}.glb"
                export_glb(obj, path)
                record["triangles"] = canonical_triangle_order(path)
                source = "composed (infinigen materials)" if recipe.is_composed else "infinigen"
                generator = f"{GENERATOR}: " + recipe.describe()
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
    if not args.no_occlusion:
        occlusion_pass(out, set(wanted), Path(args.dump_occlusion) if args.dump_occlusion else None)
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
