#!/usr/bin/env python3
"""Turn ConceptGraphs and BBQ outputs into an OSMa-Bench++ submission (docs/participants.md).

Needs Python 3.9+ and NumPy only: the pickles are read with a restricted unpickler that rebuilds
NumPy arrays (and PyTorch tensors, from the bytes torch.save wrote) and stands in for every other
class (OmegaConf configs, ConceptGraphs' own types), so neither ConceptGraphs, BBQ, PyTorch nor
OmegaConf has to be installed.

    python3 tools/osmab_export.py init --out SUB --release demo-1 --method "ConceptGraphs (ours)"
    python3 tools/osmab_export.py conceptgraphs --map full_pcd_..._post.pkl.gz \\
        --scene-graph sg_cache/scene_graph.json --lighting baseline --scene scene_000 --out SUB
    python3 tools/osmab_export.py bbq --map baseline_scene_000_with_feats.pkl.gz \\
        --nodes nodes.json --lighting baseline --scene scene_000 --out SUB
    python3 tools/osmab_export.py text-features --classes release/classes.json --embeddings emb.npy --out SUB

Maps are written as maps/<lighting>/<scene>.npz (points float32 in the release's world frame,
object_ids int64, per-object features float32 or labels int64); scene graphs as
graphs/<lighting>/<scene>.json. Background objects (walls, floor, ceiling) are left out, as the
OSMa-Bench adaptors leave them out.
"""

import argparse
import gzip
import io
import json
import os
import pickle
import sys
import zipfile

import numpy as np

# ---------------------------------------------------------------- reading pickles without their packages


class Stand_in:
    """Whatever a pickle builds that is not NumPy or a plain Python type (OmegaConf, ...)."""

    def __init__(self, *args, **kwargs):
        self.args = args

    def __setstate__(self, state):
        self.state = state

    def __call__(self, *args, **kwargs):
        return Stand_in(*args)

    def __getattr__(self, name):
        if name.startswith("__"):
            raise AttributeError(name)
        return Stand_in()


_TORCH_DTYPES = {
    "DoubleStorage": np.float64, "FloatStorage": np.float32, "HalfStorage": np.float16, "BFloat16Storage": None,
    "LongStorage": np.int64, "IntStorage": np.int32, "ShortStorage": np.int16, "CharStorage": np.int8,
    "ByteStorage": np.uint8, "BoolStorage": np.bool_,
}


class _StorageType:
    def __init__(self, name):
        self.name = name


def _rebuild_tensor(storage, offset, size, stride, *rest):
    """torch._utils._rebuild_tensor_v2 as a NumPy array (a copy, contiguous)."""
    itemsize = storage.dtype.itemsize
    view = np.lib.stride_tricks.as_strided(storage[offset:], shape=tuple(size), strides=tuple(s * itemsize for s in stride))
    return np.array(view)


def _load_from_bytes(data):
    """torch.storage._load_from_bytes: the zip torch.save writes, its storages as NumPy arrays."""
    archive = zipfile.ZipFile(io.BytesIO(data))
    names = archive.namelist()
    pkl = next(n for n in names if n.endswith("data.pkl"))
    root = pkl[: -len("data.pkl")]

    class TorchUnpickler(SafeUnpickler):
        def persistent_load(self, pid):
            # ('storage', storage_type, key, location, numel)
            storage_type, key = pid[1], pid[2]
            name = storage_type.name if isinstance(storage_type, _StorageType) else str(storage_type)
            dtype = _TORCH_DTYPES.get(name)
            if dtype is None:
                raise pickle.UnpicklingError(f"tensor storage {name} is not supported; convert it to float32 first")
            return np.frombuffer(archive.read(f"{root}data/{key}"), dtype=dtype)

    return TorchUnpickler(io.BytesIO(archive.read(pkl))).load()


class SafeUnpickler(pickle.Unpickler):
    """Rebuilds NumPy arrays and PyTorch tensors; everything else becomes a Stand_in."""

    def find_class(self, module, name):
        if module.split(".")[0] == "numpy" and name in ("_reconstruct", "ndarray", "dtype", "scalar", "_frombuffer"):
            import importlib
            import warnings
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", DeprecationWarning)
                try:
                    return getattr(importlib.import_module(module), name)
                except ImportError:  # NumPy 1 pickles name numpy.core, NumPy 2 numpy._core
                    return getattr(importlib.import_module(module.replace("numpy._core", "numpy.core").replace("numpy.core", "numpy._core", 1)), name)
        if module == "builtins" and name in ("set", "frozenset", "slice", "range", "complex", "bytearray", "list", "dict", "tuple"):
            return getattr(__import__("builtins"), name)
        if module == "collections" and name in ("OrderedDict", "defaultdict"):
            return getattr(__import__("collections"), name)
        if module == "torch._utils" and name == "_rebuild_tensor_v2":
            return _rebuild_tensor
        if module == "torch.storage" and name == "_load_from_bytes":
            return _load_from_bytes
        if module == "torch" and name.endswith("Storage"):
            return _StorageType(name)
        return Stand_in


def load_pickle(path):
    """A .pkl or .pkl.gz file, read with the restricted unpickler."""
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rb") as f:
        return SafeUnpickler(f).load()


# ---------------------------------------------------------------- the submission layout


class ExportError(Exception):
    pass


def _array(value, what, ndim=None, cols=None):
    array = np.asarray(value)
    if ndim is not None and array.ndim != ndim:
        raise ExportError(f"{what}: expected {ndim} dimensions, found shape {array.shape}")
    if cols is not None and array.shape[-1] != cols:
        raise ExportError(f"{what}: expected {cols} columns, found shape {array.shape}")
    if array.dtype.kind == "f" and not np.isfinite(array).all():
        raise ExportError(f"{what}: holds NaN or infinite values")
    return array


def write_map(out, lighting, scene, objects, feature_key):
    """objects: dicts with 'pcd_np' (N, 3) and the feature under feature_key; returns (points, objects)."""
    points, object_ids, features = [], [], []
    for i, obj in enumerate(objects):
        pcd = _array(obj["pcd_np"], f"object {i}: pcd_np", ndim=2, cols=3)
        if len(pcd) == 0:
            continue
        feature = _array(obj[feature_key], f"object {i}: {feature_key}").reshape(-1).astype(np.float32)
        points.append(pcd.astype(np.float32))
        object_ids.append(np.full(len(pcd), len(features), dtype=np.int64))
        features.append(feature)
    if not features:
        raise ExportError("the map has no object with points")
    dims = {f.shape[0] for f in features}
    if len(dims) != 1:
        raise ExportError(f"object features have different lengths: {sorted(dims)}")
    path = os.path.join(out, "maps", lighting, f"{scene}.npz")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    np.savez_compressed(path, points=np.concatenate(points), object_ids=np.concatenate(object_ids), features=np.stack(features))
    return sum(len(p) for p in points), len(features)


def write_graph(out, lighting, scene, nodes):
    if not isinstance(nodes, list) or not all(isinstance(n, dict) for n in nodes):
        raise ExportError("the scene graph must be a list of nodes (ConceptGraphs scene_graph.json, BBQ nodes JSON)")
    for i, n in enumerate(nodes):
        for key in ("bbox_center", "bbox_extent"):
            v = n.get(key)
            if not (isinstance(v, list) and len(v) == 3 and all(isinstance(x, (int, float)) for x in v)):
                raise ExportError(f"node {i}: {key} must be three numbers")
    path = os.path.join(out, "graphs", lighting, f"{scene}.json")
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "w") as f:
        json.dump(nodes, f)
    return len(nodes)


def conceptgraphs_objects(data):
    """The foreground objects of a ConceptGraphs *_post.pkl.gz (to_serializable dicts)."""
    if not isinstance(data, dict) or "objects" not in data:
        raise ExportError("not a ConceptGraphs map: expected a dict with 'objects' (a *_post.pkl.gz from pcd_saves/)")
    objects = [o for o in data["objects"] if isinstance(o, dict) and not o.get("is_background", False)]
    for i, o in enumerate(objects):
        for key in ("pcd_np", "clip_ft"):
            if key not in o:
                raise ExportError(f"object {i} has no '{key}'")
    return objects


def bbq_objects(data):
    """The objects of a BBQ map (*_with_feats.pkl.gz, which carries clip_ft)."""
    objects = data.get("objects") if isinstance(data, dict) else data
    if not isinstance(objects, list):
        raise ExportError("not a BBQ map: expected {'objects': [...]} ")
    for i, o in enumerate(objects):
        if "pcd_np" not in o:
            raise ExportError(f"object {i} has no 'pcd_np'")
        if "clip_ft" not in o:
            raise ExportError(f"object {i} has no 'clip_ft': export the map with features (the OSMa adaptor's *_with_feats.pkl.gz)")
    return objects


def cmd_init(args):
    os.makedirs(args.out, exist_ok=True)
    method = {"name": args.method, "description": args.description}
    if args.paper_url:
        method["paper_url"] = args.paper_url
    if args.code_url:
        method["code_url"] = args.code_url
    with open(os.path.join(args.out, "submission.json"), "w") as f:
        json.dump({"format": "osmab-submission/1", "release": args.release, "method": method}, f, indent=2)
    print(f"{args.out}/submission.json written")


def cmd_text_features(args):
    with open(args.classes) as f:
        classes = json.load(f)["classes"]
    ids = np.array([c["id"] for c in classes], dtype=np.int64)
    embeddings = _array(np.load(args.embeddings), "embeddings", ndim=2).astype(np.float32)
    if len(embeddings) != len(ids):
        raise ExportError(f"{len(embeddings)} embeddings for {len(ids)} classes; embed every class name of classes.json in order")
    np.savez_compressed(os.path.join(args.out, "text_features.npz"), class_ids=ids, features=embeddings)
    print(f"{args.out}/text_features.npz: {len(ids)} classes × {embeddings.shape[1]} dimensions")


def cmd_method(args, objects_of, graph_arg):
    data = load_pickle(args.map)
    objects = objects_of(data)
    points, count = write_map(args.out, args.lighting, args.scene, objects, "clip_ft")
    message = f"maps/{args.lighting}/{args.scene}.npz: {count} objects, {points} points"
    graph_path = getattr(args, graph_arg)
    if graph_path:
        with open(graph_path) as f:
            nodes = write_graph(args.out, args.lighting, args.scene, json.load(f))
        message += f"; graphs/{args.lighting}/{args.scene}.json: {nodes} nodes"
    print(message)


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)
    p = sub.add_parser("init", help="write submission.json")
    p.add_argument("--out", required=True)
    p.add_argument("--release", required=True)
    p.add_argument("--method", required=True)
    p.add_argument("--description", default="")
    p.add_argument("--paper-url")
    p.add_argument("--code-url")
    p = sub.add_parser("text-features", help="text_features.npz from class-name embeddings in classes.json order")
    p.add_argument("--classes", required=True)
    p.add_argument("--embeddings", required=True, help=".npy (C, D): one row per class of classes.json, in order")
    p.add_argument("--out", required=True)
    for name, graph_flag in (("conceptgraphs", "--scene-graph"), ("bbq", "--nodes")):
        p = sub.add_parser(name, help=f"one {name} map (and scene graph) into the submission")
        p.add_argument("--map", required=True)
        p.add_argument(graph_flag)
        p.add_argument("--lighting", required=True)
        p.add_argument("--scene", required=True)
        p.add_argument("--out", required=True)
    args = parser.parse_args(argv)
    try:
        if args.command == "init":
            cmd_init(args)
        elif args.command == "text-features":
            cmd_text_features(args)
        elif args.command == "conceptgraphs":
            cmd_method(args, conceptgraphs_objects, "scene_graph")
        else:
            cmd_method(args, bbq_objects, "nodes")
    except (ExportError, pickle.UnpicklingError, OSError, ValueError, KeyError) as e:
        print(f"osmab_export: {getattr(args, 'map', '')}: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
