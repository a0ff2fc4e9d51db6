"""Check that ConceptGraphs' and BBQ's own dataset loaders read a release's sequences as we mean them to.

Usage (a venv with the loaders' own light deps; see the end of this docstring):
    VENV/bin/python bench/loaders_check.py RELEASE_DIR \
        --conceptgraphs-src /path/to/concept-graphs [--conceptgraphs-src /path/to/another/checkout ...] \
        --bbq-src /path/to/BeyondBareQueries [--bbq-src ...] \
        --gradslam-src /path/to/gradslam   # branch conceptfusion; only its datautils + geometryutils are imported
        [--lighting baseline] [--scene scene_000] [--no-dense]
        [--write-configs [--keep-configs DIR]]   # only for an old release that ships no loader configs

Every RELEASE_DIR/sequences/<lighting>/<scene>/ ships the two loader configs (dataset/src/render/loaders.rs):
  conceptgraphs_dataconfig.yaml   ConceptGraphs `dataset_config=` (dataset_name: replica + camera_params)
  bbq_config.yaml                 BBQ `main.py --config_path` (dataset: ... + nodes_constructor: ...)
Each loader is instantiated with the SHIPPED file, unmodified, exactly as the projects' scripts call it: ConceptGraphs
with dataset_config=<sequence>/conceptgraphs_dataconfig.yaml, dataset_root=RELEASE_DIR/sequences; BBQ with the
working directory set to RELEASE_DIR and the config opened as `sequences/<lighting>/<scene>/bbq_config.yaml` (its
base_dir is "sequences", relative to the release root: `cd RELEASE_DIR && python main.py --config_path sequences/...`).
A missing, unparsable or non-mapping shipped config is a failure naming the file. --write-configs instead writes
this script's own copies (to a temporary directory, or --keep-configs DIR) for releases made before configs shipped.
The shipped files themselves are checked:
  * ConceptGraphs: dataset_name replica, no inherit_from, camera_params == camera_params.yaml exactly (every key,
    same values, no extra key), read with ConceptGraphs' own load_dataset_config;
  * BBQ (read with yaml.full_load, as main.py does): dataset.name Replica, base_dir/sequence (from the release root)
    == this sequence, dataset.relative_pose is False, desired_height/width == the native size, camera_params ==
    camera_params.yaml exactly; every config key main.py reads, derived from the given BBQ checkout's source (main.py
    parsed with `ast`, followed into what it hands its config to: NodesConstructor, the classes built with
    **config[...] (their parameters without a default), postprocessing(), get_dataset() -> ReplicaDataset ->
    GradSLAMDataset; keys tested with `in` / read with .get() are optional) is present; nodes_constructor.projector
    size == native, detections_assembler.image_area == width * height, dino_generator num_patches_h/w == what
    BBQ's DINOv2 preprocessing gives for the native size (main.py reshapes its features with them).
Then every frame is read (colour, depth, intrinsics, pose) and compared with the release's own files, decoded here
independently (a small PNG decoder, traj.txt, camera_params.yaml):
  * frame counts: results/frame*.jpg, results/depth*.png, traj.txt lines and len(dataset) all equal;
  * intrinsics == camera_params, depth == png / png_depth_scale (float32), colour shape == JPEG size;
  * poses == traj.txt with relative_pose False; with ConceptGraphs' default (relative_pose True, what
    cfslam_pipeline_batch.py / streamlined_mapping.py / rerun_realtime_mapping.py get) dataset[i]'s pose ==
    inv(P0) @ Pi, but dataset.poses, which those scripts place the points with, == traj.txt;
  * BBQ: the shipped config as shipped (its stride and relative_pose) and, as a labelled in-memory modified copy,
    stride 1; `dataset.poses` and `get_cam_K()` (what BBQ's main.py projects with) == traj.txt and K;
  * ground truth (RELEASE_DIR/ground_truth/<scene>/pointcloud.pcd + semantic.npy, built from the baseline
    sequence with frames 0, 5, ... excluding the last, every 10th valid pixel): the loader's depth, intrinsics and
    poses back-projected for those frames, the same pixels selected, compared point by point and to the nearest GT
    point; the labels against results/semantic*.png; instances.npy (when present) holds one int entry per GT point
    and its per-instance counts match instances.json. Dense (all valid pixels) nearest-GT distances and a probe at
    the loaders' 480 x 640 default size are printed for information.
Printed per loader: max |diff| of intrinsics, depth (m) and poses over the frames read, and GT distances (m).
A sequence whose files change while it is checked (inode/mtime/size before vs after) fails with 'rerun'.
Third-party code is imported only from the given source paths (plus torch, numpy, opencv, imageio, natsort, PyYAML,
scipy, kornia and, for OSMa-Bench's fork, torchvision, which those modules import). Modules that a loader file imports
but never uses for loading are stubbed, and every stub is printed.
Exit status: 0 all checks pass, 1 a mismatch, 2 a usage or import error.

Venv used here (CPU, PyPI only):
    python3 -m venv VENV
    VENV/bin/pip install torch==2.5.1 numpy "opencv-python-headless<5" imageio natsort \
        pyyaml scipy kornia omegaconf
    VENV/bin/pip install torchvision==0.20.1 --no-deps   # only OSMa-Bench's fork imports it
"""
import argparse
import ast
import contextlib
import copy
import importlib
import io
import math
import os
import re
import struct
import sys
import tempfile
import traceback
import types
import warnings
import zlib
from pathlib import Path

import numpy as np

CG_DATACONFIG_NAME = "conceptgraphs_dataconfig.yaml"
BBQ_CONFIG_NAME = "bbq_config.yaml"
GT_FRAME_STRIDE = 5    # OSMa-Bench run_slam.py --stride 5 (and the last frame is never used)
GT_POINT_STRIDE = 10   # --downsample_rate 10
POINT_TOL = 1e-4       # metres: loader back-projection vs ground truth, same pixels
DENSE_SAMPLE = 100_000  # dense / probe nearest-GT statistics on at most this many points
POSE_TOL = 1e-5        # relative poses (computed in float32 by torch) vs inv(P0) @ Pi in float64
TAGS = {"ConceptGraphs": "CG", "BBQ": "BBQ"}
CAMERA_KEYS = ["image_height", "image_width", "fx", "fy", "cx", "cy", "png_depth_scale", "crop_edge"]


# --------------------------------------------------------------------------------------------------------------
# The release's own files, read without the loaders' libraries
# --------------------------------------------------------------------------------------------------------------

def read_camera_params(path):
    """camera_params.yaml as HaDaGe writes it: `camera_params:` then indented `key: number` lines."""
    values, inside = {}, False
    for raw in Path(path).read_text().splitlines():
        line = raw.split("#", 1)[0].rstrip()
        if not line.strip():
            continue
        if not line.startswith((" ", "\t")):
            inside = line.strip() == "camera_params:"
            continue
        if inside:
            key, _, value = line.strip().partition(":")
            value = value.strip().strip("'\"")
            try:
                values[key] = int(value)
            except ValueError:
                values[key] = float(value)
    missing = [k for k in CAMERA_KEYS if k not in values]
    if missing:
        raise ValueError(f"{path}: camera_params lacks {', '.join(missing)}")
    return values


def read_traj(path):
    rows = [line.split() for line in Path(path).read_text().splitlines() if line.strip()]
    if any(len(r) != 16 for r in rows):
        raise ValueError(f"{path}: every line must hold 16 numbers")
    return np.array(rows, dtype=np.float64).reshape(-1, 4, 4)


def _paeth_row(line, prev, bpp):
    cur = bytearray(len(line))
    for i in range(len(line)):
        a = cur[i - bpp] if i >= bpp else 0
        b = prev[i]
        c = prev[i - bpp] if i >= bpp else 0
        p = a + b - c
        pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
        pred = a if (pa <= pb and pa <= pc) else (b if pb <= pc else c)
        cur[i] = (line[i] + pred) & 0xFF
    return cur


def _average_row(line, prev, bpp):
    cur = bytearray(len(line))
    for i in range(len(line)):
        a = cur[i - bpp] if i >= bpp else 0
        cur[i] = (line[i] + ((a + prev[i]) >> 1)) & 0xFF
    return cur


def read_png(path):
    """Non-interlaced 8/16-bit grey or RGB(A) PNG -> (H, W) or (H, W, C) array (uint8 / uint16)."""
    data = Path(path).read_bytes()
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        raise ValueError(f"{path}: not a PNG")
    pos, idat, header = 8, [], None
    while pos < len(data):
        length, kind = struct.unpack(">I4s", data[pos:pos + 8])
        chunk = data[pos + 8:pos + 8 + length]
        pos += 12 + length
        if kind == b"IHDR":
            header = struct.unpack(">IIBBBBB", chunk)
        elif kind == b"IDAT":
            idat.append(chunk)
        elif kind == b"IEND":
            break
    width, height, depth, colour, _, _, interlace = header
    channels = {0: 1, 2: 3, 4: 2, 6: 4}.get(colour)
    if channels is None or depth not in (8, 16) or interlace:
        raise ValueError(f"{path}: PNG colour type {colour}, bit depth {depth}, interlace {interlace} not supported")
    bpp = channels * depth // 8
    stride = width * bpp
    raw = zlib.decompress(b"".join(idat))
    out = np.empty((height, stride), np.uint8)
    prev = bytes(stride)
    for y in range(height):
        off = y * (stride + 1)
        kind, line = raw[off], raw[off + 1:off + 1 + stride]
        if kind == 0:
            cur = np.frombuffer(line, np.uint8)
        elif kind == 1:
            cur = (np.frombuffer(line, np.uint8).reshape(-1, bpp).astype(np.uint64).cumsum(0) & 0xFF).astype(np.uint8).ravel()
        elif kind == 2:
            cur = np.frombuffer(line, np.uint8) + np.frombuffer(prev, np.uint8)
        elif kind == 3:
            cur = np.frombuffer(bytes(_average_row(line, prev, bpp)), np.uint8)
        elif kind == 4:
            cur = np.frombuffer(bytes(_paeth_row(line, prev, bpp)), np.uint8)
        else:
            raise ValueError(f"{path}: bad PNG filter {kind} in row {y}")
        out[y] = cur
        prev = out[y].tobytes()
    pixels = np.frombuffer(out.tobytes(), ">u2" if depth == 16 else np.uint8).astype(np.uint16 if depth == 16 else np.uint8)
    return pixels.reshape(height, width) if channels == 1 else pixels.reshape(height, width, channels)


def jpeg_size(path):
    """(width, height, components) from a JPEG's SOF marker."""
    data = Path(path).read_bytes()
    pos = 2
    while pos < len(data):
        if data[pos] != 0xFF:
            raise ValueError(f"{path}: bad JPEG marker at {pos}")
        marker = data[pos + 1]
        if marker in (0xD8, 0x01) or 0xD0 <= marker <= 0xD7:
            pos += 2
            continue
        length = struct.unpack(">H", data[pos + 2:pos + 4])[0]
        if marker in (0xC0, 0xC1, 0xC2, 0xC3, 0xC5, 0xC6, 0xC7, 0xC9, 0xCA, 0xCB, 0xCD, 0xCE, 0xCF):
            height, width, components = struct.unpack(">HHB", data[pos + 5:pos + 10])
            return width, height, components
        pos += 2 + length
    raise ValueError(f"{path}: no SOF marker")


def read_pcd(path):
    """Points (N, 3) float64 of an ASCII or binary PCD (as Open3D writes it)."""
    data = Path(path).read_bytes()
    header, pos = {}, 0
    while True:
        end = data.index(b"\n", pos)
        line = data[pos:end].decode("ascii").strip()
        pos = end + 1
        if not line or line.startswith("#"):
            continue
        key, *rest = line.split()
        header[key.upper()] = rest
        if key.upper() == "DATA":
            break
    fields, sizes, types_ = header["FIELDS"], [int(s) for s in header["SIZE"]], header["TYPE"]
    counts = [int(c) for c in header.get("COUNT", ["1"] * len(fields))]
    n = int(header["POINTS"][0])
    kind = header["DATA"][0].lower()
    if kind == "binary":
        dtype = np.dtype([(f, f"<{ {'F': 'f', 'U': 'u', 'I': 'i'}[t] }{s}", (c,) if c > 1 else ())
                          for f, s, t, c in zip(fields, sizes, types_, counts)])
        rec = np.frombuffer(data, dtype, n, pos)
        return np.stack([rec["x"], rec["y"], rec["z"]], 1).astype(np.float64)
    if kind == "ascii":
        table = np.loadtxt(io.BytesIO(data[pos:]), ndmin=2)
        return table[:n, [fields.index("x"), fields.index("y"), fields.index("z")]].astype(np.float64)
    raise ValueError(f"{path}: PCD DATA {kind} not supported")


# --------------------------------------------------------------------------------------------------------------
# This script's own copies of the loader configs: only with --write-configs, for releases made before they shipped
# --------------------------------------------------------------------------------------------------------------

def _num(v):
    return repr(v) if isinstance(v, float) else str(v)


def _camera_block(cam, indent):
    pad = " " * indent
    return "".join(f"{pad}{k}: {_num(cam[k])}\n" for k in CAMERA_KEYS)


def conceptgraphs_dataconfig(cam, lighting, scene):
    return (
        f"# ConceptGraphs dataset config for sequences/{lighting}/{scene}: pass as dataset_config=<this file>,\n"
        f"# dataset_root=<release>/sequences, scene_id={lighting}/{scene} (absolute paths: Hydra changes directory).\n"
        "# dataset_name 'replica' selects ReplicaDataset: results/frame*.jpg, results/depth*.png, traj.txt.\n"
        "dataset_name: replica\n"
        "camera_params:\n" + _camera_block(cam, 2)
    )


def dino_patches(height, width, load_size=448, patch=14, stride=7):
    """num_patches_h/w of BBQ's DINOv2 extractor: torchvision Resize(load_size) on the short side, pad to a
    multiple of the patch size, then 1 + (side - patch) // stride."""
    if height <= width:
        h, w = load_size, int(load_size * width / height)
    else:
        h, w = int(load_size * height / width), load_size
    h, w = h + (-h) % patch, w + (-w) % patch
    return 1 + (h - patch) // stride, 1 + (w - patch) // stride


def bbq_config(cam, lighting, scene):
    h, w = cam["image_height"], cam["image_width"]
    ph, pw = dino_patches(h, w)
    return (
        f"# BeyondBareQueries config for sequences/{lighting}/{scene}. Run from the release directory (the one\n"
        "# holding sequences/), or make base_dir absolute:\n"
        f"#   python <BeyondBareQueries>/main.py --config_path sequences/{lighting}/{scene}/{BBQ_CONFIG_NAME}\n"
        "# relative_pose must stay False: main.py builds objects with the poses of dataset[i] but projects them with\n"
        "# dataset.poses (always traj.txt); True would also put the map in the first camera's frame.\n"
        "dataset:\n"
        '  name: "Replica"\n'
        '  base_dir: "sequences"\n'
        f'  sequence: "{lighting}/{scene}"\n'
        "  start: 0\n"
        "  end: -1\n"
        "  stride: 5\n"
        f"  desired_height: {h}\n"
        f"  desired_width: {w}\n"
        "  camera_params:\n" + _camera_block(cam, 4) +
        "  relative_pose: False\n"
        '  device: "cpu"\n'
        "\n"
        "nodes_constructor:\n"
        "  mask_generator:\n"
        '    model: "MobileSAM"\n'
        '    weights_path: "/home/docker_user/bbq_weights/mobilesamv2/weight"\n'
        "  dino_generator:\n"
        '    model: "dinov2_vits14_reg_lc"\n'
        "    load_size: 448\n"
        "    stride: 7\n"
        '    facet: "value"\n'
        f"    num_patches_h: {ph}\n"
        f"    num_patches_w: {pw}\n"
        "  detections_assembler:\n"
        "    mask_conf_threshold: 0.95\n"
        "    mask_area_threshold: 500\n"
        "    max_bbox_area_ratio: 0.75\n"
        "    min_points_threshold: 150\n"
        "    downsample_voxel_size: 0.025\n"
        "    dbscan_remove_noise: True\n"
        "    dbscan_eps: 0.05\n"
        "    dbscan_min_points: 10\n"
        f"    image_area: {h * w} # desired_height * desired_width\n"
        "  objects_associator:\n"
        "    merge_det_obj_spatial_sim_thresh: 0.01\n"
        "    merge_det_obj_visual_sim_thresh: 0.5\n"
        "    downsample_voxel_size: 0.025\n"
        "    merge_interval: 20\n"
        "    merge_objects_overlap_thresh: 0.7\n"
        "    merge_objects_visual_sim_thresh: 0.4\n"
        "  projector:\n"
        "    num_views: 5\n"
        "    top_k: 1\n"
        f"    desired_height: {h}\n"
        f"    desired_width: {w}\n"
        "  postprocessing:\n"
        "    obj_min_points: 150\n"
        "    obj_min_detections: 3\n"
        f'  output_path: "bbq_output/{lighting}"\n'
        f'  output_name_nodes: "{scene}.json"\n'
        f'  output_name_objects: "{scene}_objects.pkl.gz"\n'
    )


# --------------------------------------------------------------------------------------------------------------
# The shipped configs
# --------------------------------------------------------------------------------------------------------------

def read_shipped_yaml(path, shown):
    """(mapping, None) or (None, one-line failure naming `shown`): yaml.full_load, as both projects read them."""
    import yaml  # the loaders' own dependency
    if not Path(path).is_file():
        return None, f"{shown}: shipped config missing"
    try:
        with open(path) as fh:
            data = yaml.full_load(fh)
    except Exception as exc:
        return None, f"{shown}: unparsable YAML ({' '.join(str(exc).split())[:200]})"
    if not isinstance(data, dict):
        return None, f"{shown}: not a YAML mapping (got {type(data).__name__})"
    return data, None


INT_CAMERA_KEYS = ("image_height", "image_width", "crop_edge")


def camera_mismatches(shipped, cam):
    """How a shipped camera_params block differs from camera_params.yaml: every key, the same value (ints where
    camera_params.yaml has sizes), no extra key."""
    if not isinstance(shipped, dict):
        return [f"camera_params is {type(shipped).__name__}, not a mapping"]
    bad = []
    for key, want in cam.items():
        if key not in shipped:
            bad.append(f"{key} missing")
            continue
        got = shipped[key]
        if isinstance(got, bool) or not isinstance(got, (int, float)) or got != want \
                or (key in INT_CAMERA_KEYS and not isinstance(got, int)):
            bad.append(f"{key} {got!r} != {want!r}")
    bad += [f"extra key {key}" for key in shipped if key not in cam]
    return bad


def dino_patch_size(model):
    """The ViT patch size in a DINO model name (dinov2_vits14_reg_lc -> 14), or None."""
    found = re.search(r"vit[a-z]*?(\d+)", str(model))
    return int(found.group(1)) if found else None


def check_shipped_conceptgraphs(seq, module, path, rep, label):
    """The dataconfig as ConceptGraphs' load_dataset_config returns it."""
    cfg = module.load_dataset_config(str(path))
    rep.check(str(cfg.get("dataset_name", "")).lower() == "replica", f"{label}: {path.name} dataset_name",
              f"{cfg.get('dataset_name')!r}, not replica")
    rep.check("inherit_from" not in cfg, f"{label}: {path.name} inherit_from", "resolved against the working directory")
    bad = camera_mismatches(cfg.get("camera_params"), seq.cam)
    rep.check(not bad, f"{label}: {path.name} camera_params vs camera_params.yaml", "; ".join(bad))
    return not bad


def check_shipped_bbq(seq, config, reads, rep, label, shown):
    """bbq_config.yaml's values (as yaml.full_load gives them to main.py); `reads`: bbq_config_reads(src)."""
    h, w = seq.cam["image_height"], seq.cam["image_width"]
    ds = config.get("dataset")
    nc = config.get("nodes_constructor")
    # Every key main.py reads (derived from source); report only the outermost missing one of each branch.
    missing = []
    for keys, where in sorted(reads.items()):
        node, ok = config, True
        for depth, key in enumerate(keys):
            if not isinstance(node, dict) or key not in node:
                ok = False
                break
            node = node[key]
        if not ok and keys[:depth + 1] not in [m[0] for m in missing]:
            missing.append((keys[:depth + 1], where))
    rep.check(not missing, f"{label}: {shown} keys main.py reads",
              "; ".join(f"{'.'.join(k)} missing (read at {where})" for k, where in missing))
    if not isinstance(ds, dict):
        return
    rep.check(ds.get("name") == "Replica", f"{label}: {shown} dataset.name", f"{ds.get('name')!r}")
    rep.check(ds.get("relative_pose", "absent (BBQ's default True)") is False, f"{label}: {shown} dataset.relative_pose",
              f"{ds.get('relative_pose', 'absent (default True)')!r}, not False")
    size = (ds.get("desired_height"), ds.get("desired_width"))
    rep.check(size == (h, w) and all(type(v) is int for v in size), f"{label}: {shown} dataset.desired_height/width",
              f"{size} != native {(h, w)}")
    bad = camera_mismatches(ds.get("camera_params"), seq.cam)
    rep.check(not bad, f"{label}: {shown} dataset.camera_params vs camera_params.yaml", "; ".join(bad))
    where = os.path.realpath(os.path.join(seq.release, str(ds.get("base_dir")), str(ds.get("sequence"))))
    rep.check(where == os.path.realpath(seq.dir), f"{label}: {shown} base_dir/sequence",
              f"{ds.get('base_dir')!r}/{ds.get('sequence')!r} from the release root is {where}, not {seq.dir}")
    if not isinstance(nc, dict):
        return
    projector = nc.get("projector") or {}
    psize = (projector.get("desired_height"), projector.get("desired_width"))
    rep.check(psize == (h, w), f"{label}: {shown} nodes_constructor.projector size", f"{psize} != native {(h, w)}")
    area = (nc.get("detections_assembler") or {}).get("image_area")
    rep.check(area == h * w, f"{label}: {shown} nodes_constructor.detections_assembler.image_area", f"{area} != {h * w}")
    dino = nc.get("dino_generator") or {}
    patch = dino_patch_size(dino.get("model"))
    if patch and isinstance(dino.get("load_size"), int) and isinstance(dino.get("stride"), int):
        want = dino_patches(h, w, dino["load_size"], patch, dino["stride"])
        got = (dino.get("num_patches_h"), dino.get("num_patches_w"))
        rep.check(got == want, f"{label}: {shown} nodes_constructor.dino_generator num_patches_h/w",
                  f"{got} != {want} (DINOv2 preprocessing of {w}x{h}: short side to {dino['load_size']}, padded to "
                  f"a multiple of {patch}, stride {dino['stride']})")


# --------------------------------------------------------------------------------------------------------------
# The config keys BBQ's main.py reads, derived from its source (parsed, never imported)
# --------------------------------------------------------------------------------------------------------------

class _PySource:
    """A checkout's Python files, parsed, with `from X import Y` followed to the definition of Y."""

    def __init__(self, root):
        self.root = Path(root)
        self._trees = {}

    def tree(self, path):
        if path not in self._trees:
            self._trees[path] = ast.parse(path.read_text(), str(path))
        return self._trees[path]

    def module_file(self, module, level, importer):
        base = self.root if level == 0 else importer.parents[level - 1]
        stem = base.joinpath(*module.split(".")) if module else base
        for candidate in (stem.parent / (stem.name + ".py"), stem / "__init__.py"):
            if candidate.is_file():
                return candidate
        return None

    def resolve(self, name, path, depth=0):
        """(file, ClassDef | FunctionDef) that the top-level name `name` of `path` refers to, or None."""
        tree = self.tree(path)
        for node in tree.body:
            if isinstance(node, (ast.ClassDef, ast.FunctionDef)) and node.name == name:
                return path, node
        if depth < 20:
            for node in tree.body:
                if isinstance(node, ast.ImportFrom):
                    for alias in node.names:
                        if (alias.asname or alias.name) == name:
                            target = self.module_file(node.module or "", node.level, path)
                            if target is not None:
                                return self.resolve(alias.name, target, depth + 1)
        return None

    def where(self, path, node):
        return f"{path.relative_to(self.root)}:{node.lineno}"


def _ref(expr):
    if isinstance(expr, ast.Name):
        return expr.id
    if isinstance(expr, ast.Attribute) and isinstance(expr.value, ast.Name):
        return f"{expr.value.id}.{expr.attr}"
    return None


def _key_path(expr, roots):
    """The config key path of `root["a"]["b"]` (or of a bare root), roots: {name or self.attr: its key path}."""
    keys = []
    while isinstance(expr, ast.Subscript):
        key = expr.slice.value if isinstance(expr.slice, getattr(ast, "Index", ())) else expr.slice  # Index: < 3.9
        if not (isinstance(key, ast.Constant) and isinstance(key.value, str)):
            return None
        keys.append(key.value)
        expr = expr.value
    ref = _ref(expr)
    return roots[ref] + tuple(reversed(keys)) if ref in roots else None


def _params(fn, method):
    """(positional parameter names, names without a default, **kwargs name) of a def (minus self for a method)."""
    a = fn.args
    positional = [x.arg for x in a.posonlyargs + a.args]
    required = positional[:len(positional) - len(a.defaults)]
    if method:
        positional, required = positional[1:], required[1:]
    required += [x.arg for x, d in zip(a.kwonlyargs, a.kw_defaults) if d is None]
    return positional + [x.arg for x in a.kwonlyargs], required, (a.kwarg.arg if a.kwarg else None)


def _callee(src, path, func, cls):
    """(file, def, class or None) that a call goes to: a top-level name of `path` (defined or imported; a class
    means its __init__), or super().__init__ inside `cls`."""
    if isinstance(func, ast.Name):
        hit = src.resolve(func.id, path)
    elif (isinstance(func, ast.Attribute) and func.attr == "__init__" and isinstance(func.value, ast.Call)
          and isinstance(func.value.func, ast.Name) and func.value.func.id == "super" and cls is not None
          and cls.bases and isinstance(cls.bases[0], ast.Name)):
        hit = src.resolve(cls.bases[0].id, path)
    else:
        return None
    if hit is None:
        return None
    hpath, node = hit
    if isinstance(node, ast.ClassDef):
        init = next((b for b in node.body if isinstance(b, ast.FunctionDef) and b.name == "__init__"), None)
        return (hpath, init, node) if init is not None else None
    return hpath, node, None


def _config_reads(src, path, fn, roots, found, seen, cls=None):
    """Record in `found` {key path: where} every constant-key read of the config parts in `roots` inside `fn`,
    following them into the calls they are passed to."""
    key = (path, fn.lineno, tuple(sorted(roots.items())))
    if key in seen:
        return
    seen.add(key)
    optional = set()  # `"k" in cfg` or cfg.get("k"): not required
    for node in ast.walk(fn):
        if isinstance(node, ast.Compare) and isinstance(node.left, ast.Constant) \
                and any(isinstance(op, (ast.In, ast.NotIn)) for op in node.ops):
            container = node.comparators[0]
            if isinstance(container, ast.Call) and isinstance(container.func, ast.Attribute) \
                    and container.func.attr == "keys" and not container.args:
                container = container.func.value  # "k" in cfg.keys()
            p = _key_path(container, roots)
            if p is not None:
                optional.add(p + (node.left.value,))
        elif isinstance(node, ast.Call) and isinstance(node.func, ast.Attribute) and node.func.attr == "get" \
                and node.args and isinstance(node.args[0], ast.Constant):
            p = _key_path(node.func.value, roots)
            if p is not None:
                optional.add(p + (node.args[0].value,))
    attrs = {}
    for node in ast.walk(fn):
        if isinstance(node, ast.Subscript):
            p = _key_path(node, roots)
            if p and not any(p[:len(o)] == o for o in optional):
                found.setdefault(p, src.where(path, node))
        elif isinstance(node, ast.Assign) and cls is not None:
            p = _key_path(node.value, roots)
            if p is not None:
                attrs.update({_ref(t): p for t in node.targets if (_ref(t) or "").startswith("self.")})
        elif isinstance(node, ast.Call):
            target = _callee(src, path, node.func, cls)
            if target is None:
                continue
            tpath, tfn, tcls = target
            positional, required, kwarg = _params(tfn, tcls is not None)
            given = set(positional[:len(node.args)]) | {kw.arg for kw in node.keywords if kw.arg}
            for i, arg in enumerate(node.args):
                p = _key_path(arg, roots)
                if p is not None and i < len(positional):
                    _config_reads(src, tpath, tfn, {positional[i]: p}, found, seen, tcls)
            for kw in node.keywords:
                p = _key_path(kw.value, roots)
                if p is None:
                    continue
                if kw.arg is None:  # f(**cfg): f's parameters without a default must be keys of cfg
                    for name in required:
                        if name not in given:
                            found.setdefault(p + (name,), src.where(tpath, tfn))
                    if kwarg:
                        _config_reads(src, tpath, tfn, {kwarg: p}, found, seen, tcls)
                elif kw.arg in positional:
                    _config_reads(src, tpath, tfn, {kw.arg: p}, found, seen, tcls)
    if cls is not None and attrs:  # self.config = config in __init__: the other methods read it too
        for item in cls.body:
            if isinstance(item, ast.FunctionDef) and item is not fn:
                _config_reads(src, path, item, attrs, found, seen, cls)


def bbq_config_reads(bbq_src):
    """{key path: where it is read} of the config BBQ's main.py loads with yaml (`config = yaml.full_load(...)`),
    followed through the code main.py hands parts of it to. Raises if main.py's config cannot be found."""
    src = _PySource(bbq_src)
    main_py = Path(bbq_src) / "main.py"
    found, seen = {}, set()
    for fn in (n for n in ast.walk(src.tree(main_py)) if isinstance(n, ast.FunctionDef)):
        for node in ast.walk(fn):
            if isinstance(node, ast.Assign) and isinstance(node.value, ast.Call) \
                    and isinstance(node.value.func, ast.Attribute) and _ref(node.value.func.value) == "yaml" \
                    and node.value.func.attr in ("full_load", "safe_load", "load", "unsafe_load"):
                for target in node.targets:
                    if isinstance(target, ast.Name):
                        _config_reads(src, main_py, fn, {target.id: ()}, found, seen)
    sections = {k[0] for k in found}
    if "nodes_constructor" not in sections or not any(len(k) > 1 and k[0] == "nodes_constructor" for k in found):
        raise RuntimeError(f"{main_py}: found no config['nodes_constructor'][...] read (found {sorted(sections)})")
    return found


def describe_reads(reads):
    """'dataset: a, b.c; nodes_constructor: ...' of the leaf key paths."""
    leaves = [k for k in reads if not any(o != k and o[:len(k)] == k for o in reads)]
    by_section = {}
    for k in sorted(leaves):
        by_section.setdefault(k[0], []).append(".".join(k[1:]) or "(whole)")
    return "; ".join(f"{section}: {', '.join(keys)}" for section, keys in by_section.items())


# --------------------------------------------------------------------------------------------------------------
# Importing the third-party loaders in isolation
# --------------------------------------------------------------------------------------------------------------

class _NotForLoading:
    """Stand-in for a class a loader module imports but never uses to load data."""

    def __init__(self, *args, **kwargs):
        raise RuntimeError("stubbed by loaders_check.py: not used for loading")


def _purge(*prefixes):
    for name in list(sys.modules):
        if any(name == p or name.startswith(p + ".") for p in prefixes):
            del sys.modules[name]


def _package(name, path=None, **attrs):
    module = types.ModuleType(name)
    module.__path__ = [str(path)] if path else []
    module.__dict__.update(attrs)
    sys.modules[name] = module
    parent, _, child = name.rpartition(".")
    if parent in sys.modules:
        setattr(sys.modules[parent], child, module)
    return module


def _source_label(src):
    commit = Path(src) / "COMMIT"
    return f"{src} ({commit.read_text().strip()})" if commit.is_file() else str(src)


def setup_gradslam(gradslam_src, notes):
    """gradslam as ConceptGraphs (main) and BBQ import it: the real datautils and geometryutils from the given
    checkout (conceptfusion branch), without running gradslam/__init__.py (open3d, plotly, chamferdist, ...)."""
    _purge("gradslam")
    if gradslam_src is None:
        raise ImportError("this loader imports gradslam: pass --gradslam-src (gradslam/gradslam, branch conceptfusion)")
    root = Path(gradslam_src) / "gradslam"
    _package("gradslam", root)
    _package("gradslam.datasets", root / "datasets")
    _package("gradslam.geometry", root / "geometry")
    importlib.import_module("gradslam.datasets.datautils")
    importlib.import_module("gradslam.geometry.geometryutils")
    _package("gradslam.slam", root / "slam")
    _package("gradslam.slam.pointfusion", None, PointFusion=_NotForLoading)
    _package("gradslam.structures", root / "structures")
    _package("gradslam.structures.rgbdimages", None, RGBDImages=_NotForLoading)
    notes.append(f"gradslam datautils + geometryutils real from {_source_label(gradslam_src)}; package __init__s skipped; "
                 "stubbed (unused for loading): gradslam.slam.pointfusion.PointFusion, gradslam.structures.rgbdimages.RGBDImages")


def import_conceptgraphs(src, gradslam_src):
    notes = []
    _purge("conceptgraph", "gradslam")
    sys.path.insert(0, str(src))
    text = (Path(src) / "conceptgraph/dataset/datasets_common.py").read_text()
    if re.search(r"^\s*(from|import) gradslam", text, re.M):
        setup_gradslam(gradslam_src, notes)
    try:
        importlib.import_module("conceptgraph.utils.general_utils")
    except Exception as exc:  # ali-dev's general_utils pulls in the mapping stack (supervision, open_clip, ...)
        _purge("conceptgraph")

        def measure_time(func):
            return func

        _package("conceptgraph", Path(src) / "conceptgraph")
        _package("conceptgraph.utils", Path(src) / "conceptgraph/utils")
        _package("conceptgraph.utils.general_utils", None, measure_time=measure_time, to_scalar=lambda d: d.item() if hasattr(d, "item") else float(d))
        notes.append(f"stubbed conceptgraph.utils.general_utils (its import failed: {exc!r}); measure_time = identity")
    if (Path(src) / "conceptgraph/dataset/conceptgraphs_rgbd_images.py").is_file():
        try:
            importlib.import_module("conceptgraph.dataset.conceptgraphs_rgbd_images")
        except ImportError as exc:
            _package("conceptgraph.dataset.conceptgraphs_rgbd_images", None, RGBDImages=_NotForLoading)
            notes.append(f"stubbed conceptgraph.dataset.conceptgraphs_rgbd_images.RGBDImages (unused for loading; {exc!r})")
    module = importlib.import_module("conceptgraph.dataset.datasets_common")
    sys.path.remove(str(src))
    return module, notes


def import_bbq(src, gradslam_src):
    notes = []
    _purge("bbq", "gradslam")
    sys.path.insert(0, str(src))
    setup_gradslam(gradslam_src, notes)
    module = importlib.import_module("bbq.datasets.datasets")
    sys.path.remove(str(src))
    return module, notes


@contextlib.contextmanager
def quiet():
    buffer = io.StringIO()
    with warnings.catch_warnings(), contextlib.redirect_stdout(buffer):
        warnings.simplefilter("ignore")
        yield buffer


@contextlib.contextmanager
def working_directory(path):
    old = os.getcwd()
    os.chdir(path)
    try:
        yield
    finally:
        os.chdir(old)


# --------------------------------------------------------------------------------------------------------------
# Geometry
# --------------------------------------------------------------------------------------------------------------

def back_project(depth, K, pose, pixels):
    """World points of `pixels` (flat row-major indices) of `depth` (H, W) with intrinsics K and camera-to-world pose."""
    w = depth.shape[1]
    u, v = pixels % w, pixels // w
    z = depth.reshape(-1)[pixels].astype(np.float64)
    x = (u - float(K[0, 2])) * z / float(K[0, 0])
    y = (v - float(K[1, 2])) * z / float(K[1, 1])
    cam = np.stack([x, y, z, np.ones_like(z)], 1)
    world = cam @ np.asarray(pose, np.float64).T
    return world[:, :3] / world[:, 3:4]


def dense_step(n):
    """A sampling step giving at most DENSE_SAMPLE points and never in phase with GT_POINT_STRIDE."""
    step = max(1, -(-n // DENSE_SAMPLE))
    while step > 1 and math.gcd(step, GT_POINT_STRIDE) != 1:
        step += 1
    return step


def nearest_distances(query, ref, cell=0.05):
    """Distance from each query point to its nearest ref point: SciPy's k-d tree where SciPy is installed (the venv
    above has it), else a uniform grid (exact for distances <= cell, the rest by brute force over ref in chunks),
    whose cells hold thousands of points at 1200x680 and take hours there."""
    try:
        from scipy.spatial import cKDTree
    except ImportError:
        cKDTree = None
    if cKDTree is not None:
        return cKDTree(ref).query(query, workers=-1)[0]
    origin = np.minimum(query.min(0), ref.min(0)) - 2 * cell
    m = np.int64(1 << 20)

    def keys(ijk):
        return (ijk[:, 0] * m + ijk[:, 1]) * m + ijk[:, 2]

    rijk = np.floor((ref - origin) / cell).astype(np.int64)
    order = np.argsort(keys(rijk), kind="stable")
    rkeys, rsorted = keys(rijk)[order], ref[order]
    qijk = np.floor((query - origin) / cell).astype(np.int64)
    best = np.full(len(query), np.inf)
    for d in np.array(np.meshgrid([-1, 0, 1], [-1, 0, 1], [-1, 0, 1])).T.reshape(-1, 3):
        k = keys(qijk + d)
        lo, hi = np.searchsorted(rkeys, k, "left"), np.searchsorted(rkeys, k, "right")
        count = hi - lo
        for t in range(int(count.max(initial=0))):
            sel = np.nonzero(count > t)[0]
            d2 = ((query[sel] - rsorted[lo[sel] + t]) ** 2).sum(1)
            best[sel] = np.minimum(best[sel], d2)
    best = np.sqrt(best)
    far = np.nonzero(best > cell)[0]
    for start in range(0, len(far), 256):
        idx = far[start:start + 256]
        d2 = ((query[idx, None, :] - ref[None, :, :]) ** 2).sum(2)
        best[idx] = np.sqrt(d2.min(1))
    return best


# --------------------------------------------------------------------------------------------------------------
# The checks
# --------------------------------------------------------------------------------------------------------------

class Sequence:
    def __init__(self, release, lighting, scene):
        self.release, self.lighting, self.scene = release, lighting, scene
        self.rel = f"{lighting}/{scene}"
        self.dir = release / "sequences" / lighting / scene
        self.cam = read_camera_params(self.dir / "camera_params.yaml")
        self.traj = read_traj(self.dir / "traj.txt")
        results = self.dir / "results"
        self.frames = sorted(results.glob("frame*.jpg"))
        self.depths = sorted(results.glob("depth*.png"))
        self.semantics = sorted(results.glob("semantic*.png"))
        self._depth_cache = {}
        c = self.cam
        self.K = np.array([[c["fx"], 0, c["cx"]], [0, c["fy"], c["cy"]], [0, 0, 1]], np.float64)

    def depth_png(self, i):
        if i not in self._depth_cache:
            self._depth_cache[i] = read_png(self.depths[i])
        return self._depth_cache[i]

    def depth_m(self, i):
        return np.float32(self.depth_png(i).astype(np.float64) / self.cam["png_depth_scale"])

    def gt_frames(self):
        return list(range(0, max(len(self.frames) - 1, 0), GT_FRAME_STRIDE))


class Report:
    def __init__(self):
        self.failures, self.lines = [], []

    def check(self, ok, what, detail=""):
        if not ok:
            self.failures.append(f"{what}: {detail}" if detail else what)
        return ok

    def info(self, text):
        self.lines.append(text)


def frame_tensors(item):
    colour, depth, intrinsics, pose = (t.cpu().numpy() for t in item[:4])
    return colour, depth, intrinsics, pose


def merge_errors(into, errs):
    for key, value in errs.items():
        into[key] = max(into.get(key, 0.0), value)
    return into


def compare_frames(seq, ds, indices, rep, label, expect_pose, read_all=True, keep=None, errs=None):
    """Read dataset[j] for every j and compare with frame indices[j] of the release. Returns the max |diff| of the
    frames read: K (vs float32 camera_params), depth (m, vs float32 png / scale), pose (vs the expectation)."""
    h, w = seq.cam["image_height"], seq.cam["image_width"]
    k32 = np.float32(seq.K)
    bad_depth = bad_pose = bad_k = bad_colour = 0
    shapes = set()  # depth shapes other than (H, W, 1): not compared
    worst = {"K": 0.0, "depth": 0.0, "pose": 0.0}
    for j, i in enumerate(indices):
        if not read_all and j not in (0, len(indices) - 1):
            continue
        with quiet():
            colour, depth, intrinsics, pose = frame_tensors(ds[j])
        if colour.shape != (h, w, 3) or colour.min() < 0 or colour.max() > 255:
            bad_colour += 1
        if depth.shape != (h, w, 1):
            shapes.add(depth.shape)
        else:
            worst["depth"] = max(worst["depth"], float(np.abs(depth[..., 0].astype(np.float64) - seq.depth_m(i)).max()))
        if depth.shape != (h, w, 1) or not np.array_equal(depth[..., 0], seq.depth_m(i)):
            bad_depth += 1
        worst["K"] = max(worst["K"], float(np.abs(intrinsics[:3, :3].astype(np.float64) - k32).max()))
        if not np.array_equal(intrinsics[:3, :3], k32):
            bad_k += 1
        expected = expect_pose(i)
        err = float(np.abs(pose.astype(np.float64) - expected).max())
        worst["pose"] = max(worst["pose"], err)
        exact = expected.dtype == np.float32
        if (exact and not np.array_equal(pose, expected)) or (not exact and err > POSE_TOL):
            bad_pose += 1
        if keep is not None:
            keep[i] = (depth[..., 0], intrinsics[:3, :3], pose)
    n = len(indices) if read_all else min(2, len(indices))
    rep.check(bad_colour == 0, f"{label}: colour", f"{bad_colour}/{n} frames not ({h}, {w}, 3) in [0, 255]")
    rep.check(bad_depth == 0, f"{label}: depth", f"{bad_depth}/{n} frames differ from png / {seq.cam['png_depth_scale']} "
              f"(max |diff| {worst['depth']:.3g} m" + (f"; shaped {sorted(shapes)}, not compared)" if shapes else ")"))
    rep.check(bad_k == 0, f"{label}: intrinsics", f"{bad_k}/{n} frames differ from camera_params (max |diff| {worst['K']:.3g})")
    rep.check(bad_pose == 0, f"{label}: poses", f"{bad_pose}/{n} frames differ (max |diff| {worst['pose']:.3g})")
    if errs is not None:
        merge_errors(errs, worst)
    return worst


def check_conceptgraphs(seq, module, cfg_path, rep, label, keep):
    import torch  # the loaders' own dependency
    basedir = str(seq.release / "sequences")
    # What cfslam_pipeline_batch.py / streamlined_mapping.py / rerun_realtime_mapping.py do with image_height/width
    # left null: process_cfg() reads them from the dataconfig with OmegaConf.
    try:
        from omegaconf import OmegaConf
        dcfg = OmegaConf.load(cfg_path)
        size = (int(dcfg.camera_params.image_height), int(dcfg.camera_params.image_width))
    except ImportError:
        size = (seq.cam["image_height"], seq.cam["image_width"])
    common = dict(dataconfig=str(cfg_path), basedir=basedir, sequence=seq.rel, start=0, end=-1,
                  desired_height=size[0], desired_width=size[1], device="cpu", dtype=torch.float)
    n = len(seq.frames)
    f32 = np.float32(seq.traj)
    errs = {}
    with quiet():
        ds = module.get_dataset(stride=1, relative_pose=False, **common)
    rep.check(type(ds).__name__ == "ReplicaDataset", f"{label}: loader class", type(ds).__name__)
    rep.check(len(ds) == n, f"{label}: frame count", f"len(dataset) {len(ds)} != {n} frames")
    compare_frames(seq, ds, list(range(len(ds))), rep, f"{label} relative_pose=False", lambda i: f32[i], keep=keep, errs=errs)
    # The scripts' call: relative_pose not passed -> default True.
    p0inv = np.linalg.inv(seq.traj[0])
    with quiet():
        ds_default = module.get_dataset(stride=5, **common)
    rel_default = ds_default.relative_pose
    m = len(range(0, n, 5))
    rep.check(len(ds_default) == m, f"{label}: stride 5 count", f"{len(ds_default)} != {m}")
    compare_frames(seq, ds_default, list(range(0, n, 5)), rep, f"{label} default relative_pose (stride 5)",
                   (lambda i: p0inv @ seq.traj[i]) if rel_default else (lambda i: f32[i]), read_all=False)
    poses = ds_default.transformed_poses.cpu().numpy().astype(np.float64)
    expected = np.stack([p0inv @ seq.traj[i] for i in range(0, n, 5)]) if rel_default else f32[::5].astype(np.float64)
    err = float(np.abs(poses - expected).max())
    rep.check(err <= POSE_TOL, f"{label}: default-relative_pose poses", f"max |diff| {err:.3g}")
    # What the mapping scripts actually place points with: dataset.poses (never relative), not dataset[i]'s pose.
    rep.check(np.array_equal(ds_default.poses.cpu().numpy(), f32[::5]), f"{label}: dataset.poses (stride 5)", "differ from traj.txt")
    return dict(frames=len(ds), default_relative_pose=rel_default, default_pose_err=err, size=size, errs=errs)


def check_bbq(seq, module, config, rep, label, keep):
    """`config`: the shipped bbq_config.yaml as yaml.full_load gives it to main.py; call with the working directory
    set to the release root (base_dir "sequences" is relative to it). dataset[i] poses are expected as the
    loader's relative_pose (as shipped) makes them."""
    n = len(seq.frames)
    f32 = np.float32(seq.traj)
    p0inv = np.linalg.inv(seq.traj[0])
    out, errs = {}, {}
    with quiet():
        ds = module.get_dataset(config["dataset"])
    if not rep.check(isinstance(ds, module.GradSLAMDataset), f"{label}: get_dataset", f"returned {ds!r}"):
        return out
    relative = bool(ds.relative_pose)
    stride = config["dataset"].get("stride") or 1
    start = config["dataset"].get("start", 0)
    end = config["dataset"].get("end", -1)
    idx = list(range(n))[start:(None if end == -1 else end):stride]
    rep.check(len(ds) == len(idx), f"{label}: frame count (stride {stride})", f"{len(ds)} != {len(idx)}")
    expect = (lambda i: p0inv @ seq.traj[i]) if relative else (lambda i: f32[i])
    compare_frames(seq, ds, idx, rep, f"{label} shipped config (relative_pose={relative})", expect, keep=keep, errs=errs)
    # What main.py projects with: dataset.poses and get_cam_K().
    poses = ds.poses.cpu().numpy()
    rep.check(np.array_equal(poses, f32[idx]), f"{label}: dataset.poses", "differ from traj.txt")
    K = ds.get_cam_K().cpu().numpy()
    rep.check(np.array_equal(K, np.float32(seq.K)), f"{label}: get_cam_K()", f"{K.tolist()}")
    out.update(frames=len(ds), stride=stride, relative_pose=relative, errs=errs)
    # Modified copy (in memory), labelled: every frame.
    every = copy.deepcopy(config["dataset"])
    every["stride"] = 1
    with quiet():
        ds1 = module.get_dataset(every)
    rep.check(len(ds1) == n, f"{label}: frame count (stride 1, modified copy)", f"{len(ds1)} != {n}")
    compare_frames(seq, ds1, list(range(n)), rep, f"{label} stride 1 (modified copy)", expect, errs=errs)
    # Probe, not shipped: what relative_pose True would do to main.py.
    probe = copy.deepcopy(config["dataset"])
    probe["relative_pose"] = True
    with quiet():
        dsr = module.get_dataset(probe)
        item_pose = dsr[len(dsr) - 1][3].cpu().numpy()
    out["relative_true_gap"] = float(np.abs(item_pose - dsr.poses[len(dsr) - 1].cpu().numpy()).max())
    return out


def select_gt_pixels(depths):
    """Per frame, the flat indices of the valid pixels run_slam.py keeps: every 10th of the concatenated cloud."""
    seen, picks = 0, []
    for depth in depths:
        valid = np.flatnonzero(depth.reshape(-1) > 0)
        first = (GT_POINT_STRIDE - seen % GT_POINT_STRIDE) % GT_POINT_STRIDE
        picks.append(valid[first::GT_POINT_STRIDE])
        seen += len(valid)
    return picks


def check_ground_truth(seq, frames, gt_points, gt_labels, rep, label, dense=True, relative_probe=True):
    """frames: {release frame index: (depth (H, W) metres, K 3x3, pose 4x4)} from a loader."""
    gt_idx = seq.gt_frames()
    missing = [i for i in gt_idx if i not in frames]
    if not rep.check(not missing, f"{label}: GT frames read", f"loader gave no frame {missing[:5]}"):
        return {}
    depths = [frames[i][0] for i in gt_idx]
    picks = select_gt_pixels(depths)
    pts = np.concatenate([back_project(frames[i][0], frames[i][1], frames[i][2], p) for i, p in zip(gt_idx, picks)])
    out = dict(frames=len(gt_idx), points=len(pts), gt_points=len(gt_points))
    same_count = len(pts) == len(gt_points)
    if same_count:
        out["corr_max"] = float(np.linalg.norm(pts - gt_points, axis=1).max())
    nn = nearest_distances(pts, gt_points)
    out["nn_max"] = float(nn.max())
    rep.check(out["nn_max"] <= POINT_TOL, f"{label}: GT nearest distance", f"max {out['nn_max']:.4g} m > {POINT_TOL} m")
    if seq.lighting == "baseline" or same_count:
        rep.check(same_count, f"{label}: GT point count", f"{len(pts)} back-projected vs {len(gt_points)} in pointcloud.pcd")
        if same_count:
            rep.check(out["corr_max"] <= POINT_TOL, f"{label}: GT same-pixel distance", f"max {out['corr_max']:.4g} m")
            if gt_labels is not None:
                labels = np.concatenate([read_png(seq.semantics[i]).reshape(-1)[p] for i, p in zip(gt_idx, picks)])
                out["labels_equal"] = bool(np.array_equal(labels.astype(np.int64), gt_labels.astype(np.int64)))
                rep.check(out["labels_equal"], f"{label}: GT labels", "semantic.npy != results/semantic*.png at the kept pixels")
    if dense:
        all_pts = np.concatenate([back_project(frames[i][0], frames[i][1], frames[i][2],
                                               np.flatnonzero(frames[i][0].reshape(-1) > 0)) for i in gt_idx])
        d = nearest_distances(all_pts[::dense_step(len(all_pts))], gt_points)
        out["dense"] = (len(all_pts), len(d), float(np.median(d)), float(np.percentile(d, 99)), float(d.max()))
    if relative_probe:
        p0inv = np.linalg.inv(seq.traj[0])
        rel = np.concatenate([back_project(frames[i][0], frames[i][1], p0inv @ frames[i][2].astype(np.float64), p)
                              for i, p in zip(gt_idx, picks)])
        if same_count:
            gap = np.linalg.norm(rel - gt_points, axis=1)
            out["relative_gap"] = (float(np.median(gap)), float(gap.max()))
    return out


def resize_probe(seq, module, cfg_path, gt_points):
    """ConceptGraphs' ReplicaDataset at its 480 x 640 default (run_slam_rgb.py / generate_gsa_results.py defaults):
    intrinsics scaled by gradslam's scale_intrinsics (cx * ratio, no half-pixel shift); dense nearest-GT distances."""
    import torch
    with quiet():
        ds = module.get_dataset(dataconfig=str(cfg_path), basedir=str(seq.release / "sequences"), sequence=seq.rel,
                                stride=1, desired_height=480, desired_width=640, device="cpu", dtype=torch.float,
                                relative_pose=False)
    pts = []
    for i in seq.gt_frames():
        with quiet():
            _, depth, K, pose = frame_tensors(ds[i])
        pts.append(back_project(depth[..., 0], K[:3, :3], pose, np.flatnonzero(depth.reshape(-1) > 0)))
    pts = np.concatenate(pts)
    d = nearest_distances(pts[::dense_step(len(pts))], gt_points)
    return float(np.median(d)), float(np.percentile(d, 99)), K[:3, :3]


def load_ground_truth(gt_dir):
    """(points, labels or None, instance problems, instance info) of RELEASE_DIR/ground_truth/<scene>/."""
    import json
    points = read_pcd(gt_dir / "pointcloud.pcd")
    labels = np.load(gt_dir / "semantic.npy") if (gt_dir / "semantic.npy").is_file() else None
    problems, info = [], None
    npy, js = gt_dir / "instances.npy", gt_dir / "instances.json"
    if npy.is_file():
        inst = np.load(npy)
        if inst.ndim != 1 or inst.dtype.kind not in "iu":
            problems.append(f"{npy}: {inst.dtype} array of shape {inst.shape}, not 1-D integers")
        elif len(inst) != len(points):
            problems.append(f"{npy}: {len(inst)} entries for {len(points)} points in pointcloud.pcd")
        else:
            ids, counts = np.unique(inst, return_counts=True)
            info = f"instances.npy: {len(inst)} entries (one per GT point), {int((ids != 0).sum())} instances"
            if js.is_file():
                table = json.loads(js.read_text())
                listed = {int(k): v.get("points") for k, v in (table.get("instances") or {}).items()}
                found = {int(i): int(c) for i, c in zip(ids, counts) if i != 0}
                if listed != found:
                    diff = sorted(set(listed.items()) ^ set(found.items()))[:5]
                    problems.append(f"{js}: per-instance point counts differ from instances.npy (e.g. {diff})")
                unknown = int(counts[ids == 0].sum()) if (ids == 0).any() else 0
                if "unknown" in table and table["unknown"] != unknown:
                    problems.append(f"{js}: unknown {table['unknown']} != {unknown} zero entries of instances.npy")
                info += f", counts == instances.json, {unknown} unknown (0)"
    return points, labels, problems, info


def fingerprint(release, lighting, scene):
    """(inode, mtime, size) of what a sequence's check reads: changes when the release is rewritten meanwhile."""
    seq_dir = release / "sequences" / lighting / scene
    gt_dir = release / "ground_truth" / scene
    paths = [release, release / "sequences", seq_dir, seq_dir / "results", seq_dir / "traj.txt",
             seq_dir / "camera_params.yaml", seq_dir / CG_DATACONFIG_NAME, seq_dir / BBQ_CONFIG_NAME,
             gt_dir / "pointcloud.pcd", gt_dir / "semantic.npy", gt_dir / "instances.npy"]
    out = {}
    for path in paths:
        try:
            st = path.stat()
            out[str(path)] = (st.st_ino, st.st_mtime_ns, st.st_size)
        except OSError:
            out[str(path)] = None
    return out


def check_sequence(seq, rep, args, release, loaders, gt_cache, totals, config_root):
    """Every check of one sequence; returns the lines to print (failures go to rep)."""
    if args.write_configs:
        out_dir = config_root / seq.lighting / seq.scene
        out_dir.mkdir(parents=True, exist_ok=True)
        cg_path, bbq_path = out_dir / CG_DATACONFIG_NAME, out_dir / BBQ_CONFIG_NAME
        cg_path.write_text(conceptgraphs_dataconfig(seq.cam, seq.lighting, seq.scene))
        bbq_path.write_text(bbq_config(seq.cam, seq.lighting, seq.scene))
        bbq_arg = str(bbq_path)
    else:
        cg_path, bbq_path = seq.dir / CG_DATACONFIG_NAME, seq.dir / BBQ_CONFIG_NAME
        bbq_arg = str(bbq_path.relative_to(release))  # as a participant passes it from the release root
    # The shipped files, read once: missing / unparsable is one failure naming the file.
    cg_data, cg_error = read_shipped_yaml(cg_path, cg_path)
    with working_directory(release):
        bbq_data, bbq_error = read_shipped_yaml(bbq_arg, bbq_path)
    for error in (cg_error, bbq_error):
        rep.check(error is None, error or "")
    n = len(seq.frames)
    rep.check(n > 0 and n == len(seq.depths) == len(seq.traj),
              "release counts", f"{n} frame*.jpg, {len(seq.depths)} depth*.png, {len(seq.traj)} traj.txt lines")
    rep.check(len(seq.semantics) == n, "release counts", f"{len(seq.semantics)} semantic*.png for {n} frames")
    sizes = {jpeg_size(f)[:2] for f in seq.frames[:1] + seq.frames[-1:]}
    rep.check(sizes == {(seq.cam["image_width"], seq.cam["image_height"])}, "JPEG size", f"{sizes}")
    gt_dir = release / "ground_truth" / seq.scene
    lines = [f"{seq.rel}: {n} frames, {seq.cam['image_width']}x{seq.cam['image_height']}, "
             f"fx {seq.cam['fx']} cx {seq.cam['cx']} cy {seq.cam['cy']}, depth scale {seq.cam['png_depth_scale']}"]
    if seq.scene not in gt_cache and (gt_dir / "pointcloud.pcd").is_file():
        points, labels, problems, info = load_ground_truth(gt_dir)
        gt_cache[seq.scene] = (points, labels)
        for problem in problems:  # reported with the first sequence of the scene only
            rep.check(False, f"GT instances: {problem}")
        if info:
            lines.append(f"  GT {seq.scene} {info}")
    gt = gt_cache.get(seq.scene)
    for k, (kind, src, module, _, reads) in enumerate(loaders):
        tag = f"{TAGS[kind]}{k}"
        keep = {}
        if (cg_data if kind == "ConceptGraphs" else bbq_data) is None:
            lines.append(f"  [{tag}] not run: its config is missing or unparsable")
            continue
        try:
            if kind == "ConceptGraphs":
                check_shipped_conceptgraphs(seq, module, cg_path, rep, tag)
                res = check_conceptgraphs(seq, module, cg_path, rep, tag, keep)
                lines.append(f"  [{tag}] get_dataset({cg_path.name}) -> ReplicaDataset, {res['frames']} frames at "
                             f"{res['size'][1]}x{res['size'][0]}: colour/depth/K/poses (relative_pose=False) compared; "
                             f"default relative_pose={res['default_relative_pose']} -> dataset[i] poses = inv(P0)@Pi "
                             f"(max |diff| {res['default_pose_err']:.2g}) while dataset.poses (what the mapping "
                             f"scripts use) == traj.txt")
            else:
                check_shipped_bbq(seq, bbq_data, reads, rep, tag, bbq_path.name)
                with working_directory(release):
                    res = check_bbq(seq, module, bbq_data, rep, tag, keep)
                if res:
                    lines.append(f"  [{tag}] cwd {release.name}/, get_dataset(config['dataset']) {'written' if args.write_configs else 'shipped'} (stride "
                                 f"{res['stride']}, relative_pose {res['relative_pose']}): {res['frames']} frames; "
                                 f"stride 1 copy: {n} frames; dataset.poses/get_cam_K() compared; relative_pose True "
                                 f"probe: the pose of dataset[i] (integrated) and dataset.poses[i] (projected) then "
                                 f"differ by up to {res['relative_true_gap']:.3g}")
            errs = dict(res.get("errs", {})) if res else {}
            if gt is not None:
                g = check_ground_truth(seq, keep, gt[0], gt[1], rep, tag, dense=not args.no_dense and k == 0)
                if g:
                    errs["gt_nn"] = g["nn_max"]
                    if "corr_max" in g:
                        errs["gt_same_pixel"] = g["corr_max"]
                    text = (f"  [{tag}] GT {seq.scene}: {g['frames']} frames, {g['points']} kept pixels vs "
                            f"{g['gt_points']} GT points; nearest-GT max {g['nn_max']:.3g} m")
                    if "corr_max" in g:
                        text += f", same-pixel max {g['corr_max']:.3g} m"
                    if "labels_equal" in g:
                        text += f", labels {'equal' if g['labels_equal'] else 'DIFFER'}"
                    if "dense" in g:
                        d = g["dense"]
                        text += (f"\n        dense (info; {d[1]} of the {d[0]} valid pixels): nearest-GT median {d[2]:.3g} m, "
                                 f"p99 {d[3]:.3g} m, max {d[4]:.3g} m")
                    if "relative_gap" in g:
                        text += (f"\n        with relative_pose=True poses the same pixels land {g['relative_gap'][0]:.3g} m "
                                 f"(median), {g['relative_gap'][1]:.3g} m (max) from their GT points")
                    lines.append(text)
            if errs:
                lines.append(f"  [{tag}] max |diff|: " + ", ".join(f"{key} {value:.3g}" for key, value in errs.items()))
                merge_errors(totals.setdefault(tag, {}), errs)
            if kind == "ConceptGraphs" and gt is not None and not args.no_dense and k == 0:
                med, p99, K = resize_probe(seq, module, cg_path, gt[0])
                lines.append(f"  [{tag}] probe at 640x480 (loader default): K fx {K[0,0]:.4g} fy {K[1,1]:.4g} cx {K[0,2]:.4g} "
                             f"cy {K[1,2]:.4g}; dense nearest-GT median {med:.3g} m, p99 {p99:.3g} m (info; compare with the native-size dense line)")
        except Exception as exc:
            text = " ".join("".join(traceback.format_exception_only(type(exc), exc)).split())
            rep.check(False, f"{tag}: exception", text[:300])
            traceback.print_exc()
    return lines


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("release", type=Path)
    parser.add_argument("--conceptgraphs-src", type=Path, action="append", default=[])
    parser.add_argument("--bbq-src", type=Path, action="append", default=[])
    parser.add_argument("--gradslam-src", type=Path)
    parser.add_argument("--write-configs", action="store_true",
                        help="old releases only: write this script's own loader configs instead of reading the shipped ones")
    parser.add_argument("--keep-configs", type=Path, help="with --write-configs: write them under DIR/<lighting>/<scene>/")
    parser.add_argument("--lighting", action="append", help="only these lightings")
    parser.add_argument("--scene", action="append", help="only these scenes")
    parser.add_argument("--no-dense", action="store_true", help="skip the informational dense and 480x640 probes")
    args = parser.parse_args(argv)
    if args.keep_configs and not args.write_configs:
        print("--keep-configs needs --write-configs (the shipped configs are read in place)", file=sys.stderr)
        return 2

    release = args.release.resolve()
    seq_root = release / "sequences"
    if not seq_root.is_dir():
        print(f"{seq_root}: no sequences directory", file=sys.stderr)
        return 2
    selected = []  # (lighting, scene); each Sequence is read when its turn comes
    for lighting_dir in sorted(p for p in seq_root.iterdir() if p.is_dir()):
        if args.lighting and lighting_dir.name not in args.lighting:
            continue
        for scene_dir in sorted(p for p in lighting_dir.iterdir() if (p / "camera_params.yaml").is_file()):
            if args.scene and scene_dir.name not in args.scene:
                continue
            selected.append((lighting_dir.name, scene_dir.name))
    if not selected:
        print("no sequence selected", file=sys.stderr)
        return 2
    if not args.conceptgraphs_src and not args.bbq_src:
        print("give at least one --conceptgraphs-src or --bbq-src", file=sys.stderr)
        return 2

    loaders = []
    try:
        for src in args.conceptgraphs_src:
            module, notes = import_conceptgraphs(src.resolve(), args.gradslam_src and args.gradslam_src.resolve())
            loaders.append(("ConceptGraphs", src.resolve(), module, notes, None))
        for src in args.bbq_src:
            reads = bbq_config_reads(src.resolve())
            module, notes = import_bbq(src.resolve(), args.gradslam_src and args.gradslam_src.resolve())
            notes.append(f"main.py reads {len(reads)} config keys (derived from its source with ast): {describe_reads(reads)}")
            loaders.append(("BBQ", src.resolve(), module, notes, reads))
    except Exception:
        traceback.print_exc()
        return 2
    print("Loaders:")
    for n, (kind, src, module, notes, _) in enumerate(loaders):
        print(f"  [{TAGS[kind]}{n}] {kind}: {_source_label(src)}\n        module {module.__file__}")
        for note in notes:
            print(f"        {note}")
    print("Configs: " + ("WRITTEN by this script (--write-configs), not the shipped ones" if args.write_configs else
                         f"shipped, read unmodified from each sequence directory ({CG_DATACONFIG_NAME}, {BBQ_CONFIG_NAME}); "
                         f"BBQ run from {release} with --config_path sequences/<lighting>/<scene>/{BBQ_CONFIG_NAME}"))

    tmp = tempfile.TemporaryDirectory(prefix="osmab-loaders-") if args.write_configs else None
    config_root = (args.keep_configs.resolve() if args.keep_configs else Path(tmp.name)) if args.write_configs else None
    gt_cache = {}
    failed = 0
    totals = {}  # tag -> max errors over all sequences
    for lighting, scene in selected:
        rep = Report()
        before = fingerprint(release, lighting, scene)
        try:
            seq = Sequence(release, lighting, scene)
            lines = check_sequence(seq, rep, args, release, loaders, gt_cache, totals, config_root)
        except Exception as exc:
            lines = [f"{lighting}/{scene}: not checked to the end"]
            rep.check(False, "release unreadable", " ".join("".join(traceback.format_exception_only(type(exc), exc)).split())[:300])
            traceback.print_exc()
        changed = [path for path, value in fingerprint(release, lighting, scene).items() if before[path] != value]
        rep.check(not changed, "release changed while being checked (rerun)", ", ".join(changed[:4]))
        status = "OK" if not rep.failures else "MISMATCH"
        print(f"\n{status}  " + "\n".join(lines), flush=True)
        for f in rep.failures:
            print(f"    FAIL {f}")
        failed += bool(rep.failures)
    if totals:
        print("\nMax |diff| over all sequences (K vs float32 camera_params; depth m vs float32 png/scale; pose vs traj.txt "
              "or inv(P0)@Pi; GT distances m):")
        for tag, errs in totals.items():
            print(f"  [{tag}] " + ", ".join(f"{key} {value:.3g}" for key, value in errs.items()))
    if args.write_configs:
        print(f"\nconfigs written under {config_root}" + (" (temporary, removed)" if not args.keep_configs else ""))
    print(f"{len(selected) - failed} passed, {failed} failed")
    if tmp is not None:
        tmp.cleanup()
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
