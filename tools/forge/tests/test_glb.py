"""glb.py: the canonical triangle order and the occlusion texture written into a GLB's bytes."""

import base64
import json
import struct
from pathlib import Path

import numpy as np
import pytest

import glb

ROOT = Path(__file__).resolve().parents[3]

# Two small baseline JPEGs (8 × 8 grey ramp, 16 × 8 orange), made with Pillow.
RAMP = base64.b64decode(
    "/9j/4AAQSkZJRgABAQAAAQABAAD/2wBDAAUDBAQEAwUEBAQFBQUGBwwIBwcHBw8LCwkMEQ8SEhEPERETFhwXExQaFRERGCEYGh0dHx8fExciJCIeJBweHx7/2wBDAQUFBQcGBw4ICA4eFBEUHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh7/wAARCAAIAAgDASIAAhEBAxEB/8QAHwAAAQUBAQEBAQEAAAAAAAAAAAECAwQFBgcICQoL/8QAtRAAAgEDAwIEAwUFBAQAAAF9AQIDAAQRBRIhMUEGE1FhByJxFDKBkaEII0KxwRVS0fAkM2JyggkKFhcYGRolJicoKSo0NTY3ODk6Q0RFRkdISUpTVFVWV1hZWmNkZWZnaGlqc3R1dnd4eXqDhIWGh4iJipKTlJWWl5iZmqKjpKWmp6ipqrKztLW2t7i5usLDxMXGx8jJytLT1NXW19jZ2uHi4+Tl5ufo6erx8vP09fb3+Pn6/8QAHwEAAwEBAQEBAQEBAQAAAAAAAAECAwQFBgcICQoL/8QAtREAAgECBAQDBAcFBAQAAQJ3AAECAxEEBSExBhJBUQdhcRMiMoEIFEKRobHBCSMzUvAVYnLRChYkNOEl8RcYGRomJygpKjU2Nzg5OkNERUZHSElKU1RVVldYWVpjZGVmZ2hpanN0dXZ3eHl6goOEhYaHiImKkpOUlZaXmJmaoqOkpaanqKmqsrO0tba3uLm6wsPExcbHyMnK0tPU1dbX2Nna4uPk5ebn6Onq8vP09fb3+Pn6/9oADAMBAAIRAxEAPwDidN+CXT/RP/HaKKKAP//Z"
)
ORANGE = base64.b64decode(
    "/9j/4AAQSkZJRgABAQAAAQABAAD/2wBDAAUDBAQEAwUEBAQFBQUGBwwIBwcHBw8LCwkMEQ8SEhEPERETFhwXExQaFRERGCEYGh0dHx8fExciJCIeJBweHx7/2wBDAQUFBQcGBw4ICA4eFBEUHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh4eHh7/wAARCAAIABADASIAAhEBAxEB/8QAHwAAAQUBAQEBAQEAAAAAAAAAAAECAwQFBgcICQoL/8QAtRAAAgEDAwIEAwUFBAQAAAF9AQIDAAQRBRIhMUEGE1FhByJxFDKBkaEII0KxwRVS0fAkM2JyggkKFhcYGRolJicoKSo0NTY3ODk6Q0RFRkdISUpTVFVWV1hZWmNkZWZnaGlqc3R1dnd4eXqDhIWGh4iJipKTlJWWl5iZmqKjpKWmp6ipqrKztLW2t7i5usLDxMXGx8jJytLT1NXW19jZ2uHi4+Tl5ufo6erx8vP09fb3+Pn6/8QAHwEAAwEBAQEBAQEBAQAAAAAAAAECAwQFBgcICQoL/8QAtREAAgECBAQDBAcFBAQAAQJ3AAECAxEEBSExBhJBUQdhcRMiMoEIFEKRobHBCSMzUvAVYnLRChYkNOEl8RcYGRomJygpKjU2Nzg5OkNERUZHSElKU1RVVldYWVpjZGVmZ2hpanN0dXZ3eHl6goOEhYaHiImKkpOUlZaXmJmaoqOkpaanqKmqsrO0tba3uLm6wsPExcbHyMnK0tPU1dbX2Nna4uPk5ebn6Onq8vP09fb3+Pn6/9oADAMBAAIRAxEAPwCGiiivzw/Vj//Z"
)


def synthetic_glb(triangles=((0, 1, 2), (2, 3, 0)), albedo=ORANGE):
    """A textured quad as Blender's exporter lays one out: positions, normals, UVs, indices,
    then the base-colour JPEG, in one buffer; compact JSON padded with spaces."""
    positions = np.array([[0, 0, 0], [1, 0, 0], [1, 1, 0], [0, 1, 0]], dtype=np.float32).tobytes()
    normals = np.array([[0, 0, 1]] * 4, dtype=np.float32).tobytes()
    uvs = np.array([[0, 1], [1, 1], [1, 0], [0, 0]], dtype=np.float32).tobytes()
    indices = np.array(triangles, dtype=np.uint16).ravel().tobytes()
    parts = [positions, normals, uvs, indices + b"\0" * (-len(indices) % 4), albedo]
    views, offset = [], 0
    for i, part in enumerate(parts):
        length = len(indices) if i == 3 else len(part)
        view = {"buffer": 0, "byteLength": length, "byteOffset": offset}
        if i < 3:
            view["target"] = 34962
        elif i == 3:
            view["target"] = 34963
        views.append(view)
        offset += len(part)
    binary = b"".join(parts)
    binary += b"\0" * (-len(binary) % 4)
    gltf = {
        "asset": {"generator": "Khronos glTF Blender I/O v4.2.57", "version": "2.0"},
        "scene": 0,
        "scenes": [{"name": "Scene", "nodes": [0]}],
        "nodes": [{"mesh": 0, "name": "quad"}],
        "materials": [{"doubleSided": True, "name": "quad_baked", "pbrMetallicRoughness": {"baseColorTexture": {"index": 0}, "metallicFactor": 0, "roughnessFactor": 0.800000011920929}}],
        "meshes": [{"name": "quad", "primitives": [{"attributes": {"POSITION": 0, "NORMAL": 1, "TEXCOORD_0": 2}, "indices": 3, "material": 0}]}],
        "textures": [{"sampler": 0, "source": 0}],
        "images": [{"bufferView": 4, "mimeType": "image/jpeg", "name": "quad_albedo"}],
        "accessors": [
            {"bufferView": 0, "componentType": 5126, "count": 4, "max": [1, 1, 0], "min": [0, 0, 0], "type": "VEC3"},
            {"bufferView": 1, "componentType": 5126, "count": 4, "type": "VEC3"},
            {"bufferView": 2, "componentType": 5126, "count": 4, "type": "VEC2"},
            {"bufferView": 3, "componentType": 5123, "count": 3 * len(triangles), "type": "SCALAR"},
        ],
        "bufferViews": views,
        "samplers": [{"magFilter": 9729, "minFilter": 9987}],
        "buffers": [{"byteLength": len(binary)}],
    }
    text = json.dumps(gltf, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(binary), 0x004E4942) + binary
    return b"glTF" + struct.pack("<II", 2, 12 + len(body)) + body


def check_valid(data):
    """The GLB's structure: header length, both chunks aligned, views inside the buffer."""
    assert data[:4] == b"glTF" and struct.unpack_from("<II", data, 4) == (2, len(data))
    json_length, json_type = struct.unpack_from("<II", data, 12)
    assert json_type == 0x4E4F534A and json_length % 4 == 0
    bin_length, bin_type = struct.unpack_from("<II", data, 20 + json_length)
    assert bin_type == 0x004E4942 and bin_length % 4 == 0 and 28 + json_length + bin_length == len(data)
    gltf = json.loads(data[20 : 20 + json_length])
    assert gltf["buffers"][0]["byteLength"] <= bin_length < gltf["buffers"][0]["byteLength"] + 4
    for view in gltf["bufferViews"]:
        assert view["byteOffset"] % 4 == 0 and view["byteOffset"] + view["byteLength"] <= gltf["buffers"][0]["byteLength"]
    return gltf


def triangles_of(data):
    gltf, binary = glb.read(data)
    accessor = gltf["accessors"][3]
    view = gltf["bufferViews"][accessor["bufferView"]]
    return np.frombuffer(binary[view["byteOffset"] : view["byteOffset"] + 2 * accessor["count"]], dtype=np.uint16).reshape(-1, 3)


def test_read_and_write_round_trip():
    data = synthetic_glb()
    check_valid(data)
    assert glb.write(*glb.read(data)) == data


def test_canonical_triangle_order():
    triangles = [(2, 3, 0), (1, 2, 0), (3, 0, 1), (0, 2, 1)]
    data, count = glb.canonical_triangle_order(synthetic_glb(triangles))
    assert count == 4
    # Each started at its smallest index, winding kept, then sorted.
    assert triangles_of(data).tolist() == [[0, 1, 2], [0, 1, 3], [0, 2, 1], [0, 2, 3]]
    # The same triangles in any order and rotation give the same bytes.
    shuffled = [(0, 1, 3), (2, 1, 0), (1, 2, 0), (0, 2, 3)]
    assert glb.canonical_triangle_order(synthetic_glb(shuffled))[0] == data
    assert glb.canonical_triangle_order(data)[0] == data
    # Nothing but the index view changes.
    before, after = synthetic_glb(triangles), data
    index = glb.read(before)[0]["bufferViews"][3]
    start = len(before) - len(glb.read(before)[1]) + index["byteOffset"]
    assert before[:start] == after[:start] and before[start + index["byteLength"] :] == after[start + index["byteLength"] :]


def test_canonical_triangle_order_leaves_other_primitives():
    """Only triangle lists (mode 4, the default) are reordered and counted: lines stay."""
    gltf, binary = glb.read(synthetic_glb([(2, 3, 0), (1, 2, 0)]))
    gltf["meshes"][0]["primitives"][0]["mode"] = 1  # LINES
    lines = glb.write(gltf, binary)
    assert glb.canonical_triangle_order(lines) == (lines, 0)
    del gltf["meshes"][0]["primitives"][0]["mode"]
    data, count = glb.canonical_triangle_order(glb.write(gltf, binary))
    assert count == 2 and triangles_of(data).tolist() == [[0, 1, 2], [0, 2, 3]]


def test_jpeg_size():
    assert glb.jpeg_size(RAMP) == (8, 8)
    assert glb.jpeg_size(ORANGE) == (16, 8)
    with pytest.raises(glb.GlbError):
        glb.jpeg_size(b"\x89PNG....")


def test_embed_occlusion():
    original = synthetic_glb()
    embedded = glb.embed_occlusion(original, RAMP, "quad")
    gltf = check_valid(embedded)
    before, binary_before = glb.read(original)
    after, binary = glb.read(embedded)
    # The material reads the new texture, which reads the new image, which holds the JPEG.
    occlusion = after["materials"][0]["occlusionTexture"]
    assert occlusion == {"index": 1}
    texture = after["textures"][1]
    assert texture == {"sampler": 0, "source": 1}
    image = after["images"][1]
    assert image["mimeType"] == "image/jpeg" and image["name"] == "quad_occlusion"
    assert glb.image_bytes(after, binary, 1) == RAMP
    assert glb.image_bytes(after, binary, glb.base_colour_image(after)) == ORANGE
    # Every earlier buffer view keeps its place and bytes; the binary chunk only grew.
    assert after["bufferViews"][: len(before["bufferViews"])] == before["bufferViews"]
    assert binary[: len(binary_before)] == binary_before
    assert after["bufferViews"][-1]["byteOffset"] == len(binary_before)
    # The rest of the JSON is what it was.
    for key in before:
        if key not in ("materials", "textures", "images", "bufferViews", "buffers"):
            assert after[key] == before[key]
    assert {k: v for k, v in after["materials"][0].items() if k != "occlusionTexture"} == before["materials"][0]
    assert gltf == after


def test_embedding_again_replaces_and_strip_restores():
    original = synthetic_glb()
    once = glb.embed_occlusion(original, RAMP, "quad")
    assert glb.strip_occlusion(once) == original
    assert glb.strip_occlusion(original) == original
    twice = glb.embed_occlusion(once, ORANGE, "quad")
    assert len(glb.read(twice)[0]["images"]) == 2
    assert twice == glb.embed_occlusion(original, ORANGE, "quad")
    assert glb.embed_occlusion(once, RAMP, "quad") == once


def test_embed_needs_a_base_colour_texture():
    gltf, binary = glb.read(synthetic_glb())
    del gltf["materials"][0]["pbrMetallicRoughness"]["baseColorTexture"]
    with pytest.raises(glb.GlbError):
        glb.embed_occlusion(glb.write(gltf, binary), RAMP)


def test_the_pack_meshes_carry_their_occlusion():
    """Each pack GLB with an occlusion texture is its forged bytes plus that texture."""
    meshes = sorted((ROOT / "assets" / "meshes").glob("*.glb"))[:12]
    if not meshes:
        pytest.skip("no asset pack")
    for path in meshes:
        data = path.read_bytes()
        gltf, binary = glb.read(data)
        if not any("occlusionTexture" in m for m in gltf["materials"]):
            continue
        check_valid(data)
        occlusion = gltf["textures"][gltf["materials"][0]["occlusionTexture"]["index"]]["source"]
        jpeg = glb.image_bytes(gltf, binary, occlusion)
        base = glb.jpeg_size(glb.image_bytes(gltf, binary, glb.base_colour_image(gltf)))
        assert glb.jpeg_size(jpeg) == (base[0] // 2, base[1] // 2)
        name = gltf["images"][occlusion]["name"].removesuffix(glb.OCCLUSION_SUFFIX)
        assert glb.embed_occlusion(glb.strip_occlusion(data), jpeg, name) == data
