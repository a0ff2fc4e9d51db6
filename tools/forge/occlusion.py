"""The occlusion pass (`--occlusion`, and the end of forging): Cycles' ambient occlusion of
each forged mesh, baked on its own texture atlas (TEXCOORD_0) and written into its GLB as the
glTF occlusionTexture (glb.py); the catalogue changes only in each entry's `sha256`."""

import logging
import math
import tempfile
import time
from io import BytesIO
from pathlib import Path

import bpy
import numpy as np
from PIL import Image

import blender
import catalogue
import glb
import recipes

log = logging.getLogger("forge")

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
    grey = np.round(ao * 255.0).astype(np.uint8)
    buffer = BytesIO()
    Image.fromarray(grey, "L").convert("RGB").save(buffer, "JPEG", quality=AO_QUALITY)
    return buffer.getvalue()


def occlusion_pass(out, classes, dump=None):
    """Bake the occlusion of every catalogued mesh of `classes` (None: all) into its GLB (the
    geometry and the base-colour texture stay byte for byte); updates the catalogue's SHA-256."""
    catalogue_path = out / catalogue.FILE
    pack = catalogue.read(catalogue_path)
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
        blender.reset()
        with tempfile.TemporaryDirectory() as tmp:
            source = Path(tmp) / "mesh.glb"
            source.write_bytes(data)
            bpy.ops.import_scene.gltf(filepath=str(source))
        objects = [o for o in bpy.context.view_layer.objects if o.type == "MESH"]
        ao = half(occlusion_bake(objects, size, distance, kind.rests if kind is not None else "surface"))
        name = gltf["images"][glb.base_colour_image(gltf)].get("name", entry["class"]).removesuffix("_albedo")
        path.write_bytes(glb.embed_occlusion(data, occlusion_jpeg(ao), name))
        entry["sha256"] = catalogue.sha256(path)
        if dump is not None:
            dump.mkdir(parents=True, exist_ok=True)
            Image.fromarray(np.round(ao * 255.0).astype(np.uint8), "L").save(dump / f"{Path(entry['path']).stem}.png")
        log.info("%s: occlusion %d² (distance %.1f m, mean %.2f, %.0f %% under 0.5) in %.1f s", entry["path"], ao.shape[0], distance, float(ao.mean()), 100.0 * float((ao < 0.5).mean()), time.time() - clock)
        catalogue.write(catalogue_path, pack)
