"""GLB (binary glTF 2.0) helpers of the forge that need no Blender: the canonical triangle
order (variant.py writes it after every export) and the occlusion texture of the occlusion
pass, written into the GLB's own bytes (the JSON chunk gains an image, a texture and a buffer
view and the materials an `occlusionTexture`; every other byte of the binary chunk stays).

Imports json, struct and numpy only, so the tests run with a plain Python.
"""

import json
import struct

import numpy as np

MAGIC = b"glTF"
JSON_CHUNK = 0x4E4F534A
BIN_CHUNK = 0x004E4942
INDEX_TYPES = {5121: np.uint8, 5123: np.uint16, 5125: np.uint32}
OCCLUSION_SUFFIX = "_occlusion"  # the name of the image the occlusion pass adds


class GlbError(ValueError):
    pass


def _pad(data, fill):
    return data + fill * (-len(data) % 4)


def read(data):
    """(gltf JSON as a dict, binary chunk bytes) of the GLB `data`."""
    if len(data) < 20 or data[:4] != MAGIC:
        raise GlbError("not a GLB (no glTF magic)")
    version, length = struct.unpack_from("<II", data, 4)
    if version != 2:
        raise GlbError(f"GLB version {version}, expected 2")
    if length != len(data):
        raise GlbError(f"GLB header says {length} bytes, the file has {len(data)}")
    json_length, json_type = struct.unpack_from("<II", data, 12)
    if json_type != JSON_CHUNK:
        raise GlbError("the first chunk is not JSON")
    gltf = json.loads(data[20 : 20 + json_length])
    binary = b""
    offset = 20 + json_length
    if offset < len(data):
        bin_length, bin_type = struct.unpack_from("<II", data, offset)
        if bin_type != BIN_CHUNK:
            raise GlbError("the second chunk is not BIN")
        binary = bytes(data[offset + 8 : offset + 8 + bin_length])
    return gltf, binary


def write(gltf, binary):
    """A GLB of `gltf` (serialised as Blender's exporter does: compact, keys in their order)
    and the binary chunk `binary`; both chunks padded to 4 bytes (JSON with spaces, BIN with
    zeros), as glTF requires."""
    text = _pad(json.dumps(gltf, separators=(",", ":"), ensure_ascii=True).encode(), b" ")
    chunks = struct.pack("<II", len(text), JSON_CHUNK) + text
    if binary:
        binary = _pad(bytes(binary), b"\0")
        chunks += struct.pack("<II", len(binary), BIN_CHUNK) + binary
    return MAGIC + struct.pack("<II", 2, 12 + len(chunks)) + chunks


def canonical_triangle_order(data):
    """The GLB `data` with its triangle lists in one canonical order (each triangle started at
    its smallest index, winding kept; triangles sorted): Blender's exporter lists the same
    triangles in an order that varies between runs. Returns (bytes, triangles in the GLB)."""
    data = bytearray(data)
    json_length = struct.unpack_from("<I", data, 12)[0]
    gltf = json.loads(data[20 : 20 + json_length])
    binary = 20 + json_length + 8
    total = 0
    for mesh in gltf.get("meshes", []):
        for primitive in mesh["primitives"]:
            if "indices" not in primitive or primitive.get("mode", 4) != 4:
                continue
            accessor = gltf["accessors"][primitive["indices"]]
            view = gltf["bufferViews"][accessor["bufferView"]]
            start = binary + view.get("byteOffset", 0) + accessor.get("byteOffset", 0)
            dtype = np.dtype(INDEX_TYPES[accessor["componentType"]])
            count = accessor["count"]
            end = start + count * dtype.itemsize
            triangles = np.frombuffer(bytes(data[start:end]), dtype=dtype).reshape(-1, 3)
            first = triangles.argmin(axis=1)
            rotated = np.take_along_axis(triangles, (first[:, None] + np.arange(3)[None, :]) % 3, axis=1)
            ordered = rotated[np.lexsort(rotated.T[::-1])]
            total += len(ordered)
            data[start:end] = ordered.astype(dtype).tobytes()
    return bytes(data), total


def jpeg_size(data):
    """(width, height) of a baseline or progressive JPEG."""
    if data[:2] != b"\xff\xd8":
        raise GlbError("not a JPEG")
    i = 2
    while i + 4 <= len(data):
        if data[i] != 0xFF:
            i += 1
            continue
        marker = data[i + 1]
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7 or marker == 0xFF:
            i += 1 if marker == 0xFF else 2
            continue
        length = struct.unpack_from(">H", data, i + 2)[0]
        if marker in (0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF):
            height, width = struct.unpack_from(">HH", data, i + 5)
            return width, height
        i += 2 + length
    raise GlbError("no JPEG frame header")


def image_bytes(gltf, binary, image):
    """The bytes of image `image` (embedded in a buffer view)."""
    view = gltf["bufferViews"][gltf["images"][image]["bufferView"]]
    start = view.get("byteOffset", 0)
    return binary[start : start + view["byteLength"]]


def base_colour_image(gltf):
    """The image index of the (first) base-colour texture read from TEXCOORD_0."""
    for material in gltf.get("materials", []):
        info = material.get("pbrMetallicRoughness", {}).get("baseColorTexture")
        if info is not None and info.get("texCoord", 0) == 0:
            return gltf["textures"][info["index"]]["source"]
    raise GlbError("no material with a base-colour texture on TEXCOORD_0")


def strip_occlusion(data):
    """The GLB `data` without the occlusion texture an earlier occlusion pass appended (its
    image, texture and buffer view are the last ones and its bytes end the binary chunk), so
    the pass can run again from the forged bytes. A GLB without one comes back unchanged."""
    gltf, binary = read(data)
    users = [m for m in gltf.get("materials", []) if "occlusionTexture" in m]
    if not users:
        return bytes(data)
    textures = {m["occlusionTexture"]["index"] for m in users}
    if len(textures) != 1 or textures != {len(gltf["textures"]) - 1}:
        raise GlbError("the occlusion texture is not the last texture: not written by the occlusion pass")
    texture = gltf["textures"][-1]
    if texture["source"] != len(gltf["images"]) - 1 or not gltf["images"][-1].get("name", "").endswith(OCCLUSION_SUFFIX):
        raise GlbError("the occlusion image is not the last image: not written by the occlusion pass")
    view_index = gltf["images"][-1]["bufferView"]
    if view_index != len(gltf["bufferViews"]) - 1:
        raise GlbError("the occlusion image's buffer view is not the last one")
    view = gltf["bufferViews"][-1]
    if any(t.get("source") == texture["source"] for t in gltf["textures"][:-1]):
        raise GlbError("the occlusion image is used by another texture")
    for m in users:
        del m["occlusionTexture"]
    gltf["textures"].pop()
    gltf["images"].pop()
    gltf["bufferViews"].pop()
    binary = binary[: view["byteOffset"]]
    gltf["buffers"][0]["byteLength"] = len(_pad(binary, b"\0"))
    return write(gltf, binary)


def embed_occlusion(data, jpeg, name="occlusion"):
    """The GLB `data` with the JPEG `jpeg` as the occlusion texture (glTF `occlusionTexture`,
    TEXCOORD_0) of every material whose base-colour texture reads TEXCOORD_0: the image is
    appended to the binary chunk as a new buffer view (4-byte aligned), with an image and a
    texture (the base-colour texture's sampler) after the existing ones. Every existing byte of
    the binary chunk stays where it was; an occlusion texture written before is replaced."""
    gltf, binary = read(strip_occlusion(data))
    if len(gltf.get("buffers", [])) != 1 or "uri" in gltf["buffers"][0]:
        raise GlbError("expected one embedded buffer")
    offset = len(_pad(binary, b"\0"))
    binary = _pad(binary, b"\0") + bytes(jpeg)
    gltf["bufferViews"].append({"buffer": 0, "byteLength": len(jpeg), "byteOffset": offset})
    gltf.setdefault("images", []).append({"bufferView": len(gltf["bufferViews"]) - 1, "mimeType": "image/jpeg", "name": name + OCCLUSION_SUFFIX})
    texture = {"source": len(gltf["images"]) - 1}
    users = []
    for material in gltf.get("materials", []):
        info = material.get("pbrMetallicRoughness", {}).get("baseColorTexture")
        if info is not None and info.get("texCoord", 0) == 0:
            users.append(material)
            sampler = gltf["textures"][info["index"]].get("sampler")
            if sampler is not None and "sampler" not in texture:
                texture = {"sampler": sampler, **texture}
    if not users:
        raise GlbError("no material with a base-colour texture on TEXCOORD_0")
    gltf.setdefault("textures", []).append(texture)
    for material in users:
        material["occlusionTexture"] = {"index": len(gltf["textures"]) - 1}
    gltf["buffers"][0]["byteLength"] = len(_pad(binary, b"\0"))
    return write(gltf, binary)
