"""One variant of a class, in Blender: the recipe's Infinigen factory (or composed.py's
builder) run for a seed, its parts made real and joined into one mesh, turned to the object
frame (front +y, standing on z = 0, centred) and scaled into the class's size range,
decimated to its triangle budget, baked to one base-colour texture, measured (the surfaces
other objects rest on, the free floor under it) and exported as a GLB in canonical triangle
order. A seed whose mesh cannot be used raises sizing.UnusableMesh.
"""

import importlib
import math

import bpy  # first of Blender's: bmesh and mathutils come with it
import bmesh  # noqa: I001 (after bpy)
import numpy as np
from mathutils import Matrix, Vector
from mathutils.bvhtree import BVHTree

import blender
import composed
import glb
from blender import bounds
from catalogue import Measured
from recipes import ComposedRecipe
from sizing import UnusableMesh, fit, thinnest

MIN_CLEAR_HEIGHT = 0.05  # free height above a support something can stand in, metres
FRONTS = {"+y": 0.0, "-x": -90.0, "-y": 180.0, "+x": 90.0}  # degrees about z that turn a front to +y
OVER_BUDGET = 1.5  # a mesh still over this many times its budget after decimation: another seed


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
        raise UnusableMesh("the generator made no geometry")
    bpy.context.view_layer.objects.active = convertible[0]
    bpy.ops.object.make_single_user(object=True, obdata=True, material=False)
    bpy.ops.object.convert(target="MESH")
    meshes = [o for o in bpy.context.selected_objects if o.type == "MESH" and len(o.data.polygons) > 0]
    if not meshes:
        raise UnusableMesh("the generator made no faces")
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
    return scales[(thinnest(dims) + 1) % 3]


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


def spawn(recipe, seed, size_range, rng):
    """The factory's asset for `seed`, the recipe's options passed to the factory. A `sized`
    recipe draws the asset's dimensions from the class's size range with `rng` (in the
    factory's own axes: a factory facing +x has its depth along x), for factories whose own
    ranges miss the class (cabinets, wardrobes, counters, windows)."""
    options = dict(recipe.options)
    made = {}
    if recipe.sized:
        width, depth, height = (float(rng.uniform(lo, hi)) for lo, hi in size_range)
        if recipe.factory in DIMENSIONS_AT_CREATION:
            made["dimensions"] = DIMENSIONS_AT_CREATION[recipe.factory](width, depth, height)
        else:
            options["dimensions"] = Vector((depth, width, height) if recipe.front == "+x" else (width, depth, height))
    module = importlib.import_module(f"infinigen.assets.objects.{recipe.module}")
    cls = getattr(module, recipe.factory)
    return cls(factory_seed=seed, **options).spawn_asset(0, **made)


def forge_variant(kind, recipe, seed, path, shots=None):
    """One variant of the class `kind` (recipes.ForgeClass) from `recipe` and `seed`, written
    as a GLB at `path` (with contact-sheet pictures in `shots` when given); what was measured
    of it (catalogue.Measured). Raises UnusableMesh when its mesh cannot be used."""
    name = kind.name
    blender.reset()
    blender.seed_infinigen(seed)
    if isinstance(recipe, ComposedRecipe):
        composed.build(recipe.builder, seed)
    else:
        # The sized dimensions come from a generator of their own: numpy's legacy stream for
        # `seed`, the numbers the committed pack drew from the global one seeded the same.
        spawn(recipe, seed, kind.size_range, np.random.RandomState(seed))
    obj = realize_and_join(name.replace(" ", "_"))
    scale = normalise(obj, recipe.front, kind.size_range, stretch=recipe.stretch, flat_back=kind.rests == "wall")
    if scale is None:
        raise UnusableMesh(f"does not fit {kind.size_range}")
    budget, texture = kind.triangles, kind.texture
    if shots is not None:
        blender.shot(obj, shots / "original.png", "three_quarters")
    triangles = decimate(obj, budget)
    stand_centred(obj)  # decimation may move the extreme vertices
    if triangles > OVER_BUDGET * budget:
        # Thousands of small islands (a woven seat) that collapsing cannot merge: another seed.
        raise UnusableMesh(f"{triangles} triangles after decimation, over {OVER_BUDGET} × the budget of {budget}")
    blender.bake(obj, texture, name.replace(" ", "_"), panes=kind.role == "shell")
    if shots is not None:
        blender.shot(obj, shots / "baked.png", "three_quarters")
        blender.shot(obj, shots / "front.png", "front")
    lo, hi = bounds(obj)
    size = [round(float(v), 4) for v in hi - lo]
    supports, under = supports_of(obj), under_of(obj)
    blender.export_glb(obj, path)
    return Measured(size=size, scale=round(scale, 4), triangles=canonical_triangle_order(path), supports=supports, under=under)


def canonical_triangle_order(path):
    """Rewrite the GLB at `path` with its triangle lists in one canonical order (glb.py);
    returns how many triangles it holds (the exporter drops degenerate ones, so it can be
    fewer than Blender counted)."""
    data, triangles = glb.canonical_triangle_order(path.read_bytes())
    path.write_bytes(data)
    return triangles
