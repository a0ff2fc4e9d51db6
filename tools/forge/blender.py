"""The Blender helpers the forge's steps share (variant.py, composed.py, shell.py,
occlusion.py): the empty scene, Infinigen's seeding and materials, the base-colour bake, the
GLB export and the contact sheets' pictures. A leaf: it imports Blender, numpy and Infinigen,
none of the forge's own modules.
"""

import importlib
import math

import bpy  # first of Blender's: mathutils comes with it
import numpy as np
from mathutils import Vector


def reset():
    """An empty scene, rendered by Cycles on the CPU with one sample and a fixed seed."""
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    scene.render.engine = "CYCLES"
    scene.cycles.device = "CPU"
    scene.cycles.samples = 1
    scene.cycles.seed = 0


def seed_infinigen(seed):
    """Seed the global generator Infinigen draws from: its factories seed themselves from
    their `factory_seed`, but its materials (and composed.py's dressing) draw from numpy's
    global generator. The one place the forge touches global random state; the forge's own
    numbers come from generators it passes explicitly."""
    np.random.seed(seed)


def bounds(obj):
    co = np.array([v.co[:] for v in obj.data.vertices])
    return co.min(axis=0), co.max(axis=0)


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


def dress_material(obj, module, cls):
    """Infinigen's material `materials.<module>.<cls>` on `obj`, drawn from numpy's global
    generator (seeded by seed_infinigen()). Infinigen 1.15.5's materials come in two kinds:
    those that apply themselves to an object (and may add geometry nodes), and those that
    generate a material to assign."""
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


