#!/usr/bin/env python3
"""Reference OSMa-Bench semantic-segmentation scoring of one scene (NumPy + SciPy).

Usage:
    bench/.venv/bin/python bench/reference_semseg.py --gt DIR --map FILE.npz \
        --text-features FILE.npz --json OUT [--timings]

Inputs:
    DIR/pointcloud.pcd   binary PCD (FIELDS x y z rgb, float32), N points
    DIR/semantic.npy     int64 (N,) ground-truth class id per PCD point
    FILE.npz (map)       points (P,3) f32, object_ids (P,) i64 in 0..M-1, and either
                         features (M,D) f32 or labels (M,) i64
    text features npz    class_ids (C,) i64, features (C,D) f32

Algorithm (as OSMa-Bench): vocabulary V = sorted unique GT ids without 0 that have a
text feature; each object gets V[argmax cosine(object, text)] (first max wins); map
points inherit their object's class; every GT point takes the class of its nearest
map point (scipy cKDTree, k=1); confusion matrix over V + [-1] (rows GT, columns
prediction) of the GT points whose label is in V; then mIoU / fmIoU / mAcc.

Writes {"labels", "matrix", "metrics": {"miou", "fmiou", "macc"}} to OUT.  With
--timings one JSON line of stage timings (seconds) goes to stderr.
"""
import argparse
import json
import sys
import time
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

PCD_TYPES = {"F": "f", "U": "u", "I": "i"}


def read_pcd_xyz(path):
    """Return the xyz of a binary PCD file as a float32 (N,3) array."""
    with open(path, "rb") as f:
        header = {}
        while True:
            line = f.readline()
            if not line:
                raise ValueError(f"{path}: no DATA line in PCD header")
            parts = line.decode("ascii").strip().split()
            if not parts or parts[0].startswith("#"):
                continue
            header[parts[0].upper()] = parts[1:]
            if parts[0].upper() == "DATA":
                break
        if header["DATA"][0] != "binary":
            raise ValueError(f"{path}: only DATA binary is supported")
        fields, sizes, types = header["FIELDS"], header["SIZE"], header["TYPE"]
        counts = header.get("COUNT", ["1"] * len(fields))
        dtype = np.dtype([(name, f"<{PCD_TYPES[t]}{s}", (int(c),) if int(c) > 1 else ())
                          for name, s, t, c in zip(fields, sizes, types, counts)])
        n = int(header["POINTS"][0])
        data = np.fromfile(f, dtype=dtype, count=n)
    if len(data) != n:
        raise ValueError(f"{path}: expected {n} points, found {len(data)}")
    return np.stack([data["x"], data["y"], data["z"]], axis=1).astype(np.float32)


def normalize(x):
    """L2-normalise rows (like torch.nn.functional.normalize, eps=1e-12)."""
    return x / np.maximum(np.linalg.norm(x, axis=1, keepdims=True), 1e-12)


def compute_metrics(matrix, labels):
    """mIoU, fmIoU and mAcc exactly as OSMa-Bench's compute_metrics."""
    matrix = matrix.astype(np.float64)
    labels = np.asarray(labels)
    row = matrix.sum(axis=1)
    keep = (row > 0) & (labels != -1) & (labels != 0)
    tp = np.diag(matrix)[keep]
    fp = matrix.sum(axis=0)[keep] - tp
    fn = row[keep] - tp
    iou = tp / np.maximum(tp + fp + fn, 1e-7)
    gt_c = row[keep]
    return {
        "miou": float(np.mean(iou)),
        "fmiou": float(np.sum(iou * gt_c / gt_c.sum())),
        "macc": float(np.mean(tp / np.maximum(tp + fn, 1e-7))),
    }


def main():
    t_start = time.perf_counter()
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--gt", required=True, type=Path, help="GT scene directory")
    ap.add_argument("--map", required=True, type=Path, help="map npz")
    ap.add_argument("--text-features", required=True, type=Path, help="text features npz")
    ap.add_argument("--json", required=True, type=Path, help="output JSON path")
    ap.add_argument("--timings", action="store_true", help="print stage timings to stderr")
    args = ap.parse_args()
    t = {}

    t0 = time.perf_counter()
    gt_xyz = read_pcd_xyz(args.gt / "pointcloud.pcd")
    gt_labels = np.load(args.gt / "semantic.npy").astype(np.int64)
    if len(gt_labels) != len(gt_xyz):
        sys.exit(f"semantic.npy has {len(gt_labels)} labels for {len(gt_xyz)} points")
    with np.load(args.map) as m:
        map_points = m["points"].astype(np.float32)
        object_ids = m["object_ids"].astype(np.int64)
        obj_features = m["features"].astype(np.float32) if "features" in m else None
        obj_labels = m["labels"].astype(np.int64) if obj_features is None else None
    with np.load(args.text_features) as tf:
        class_ids = tf["class_ids"].astype(np.int64)
        text_features = tf["features"].astype(np.float32)
    t["load_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    vocab = np.unique(gt_labels)
    vocab = vocab[(vocab != 0) & np.isin(vocab, class_ids)]
    if obj_features is not None:
        row_of = {int(c): i for i, c in enumerate(class_ids)}
        text = normalize(text_features[[row_of[int(c)] for c in vocab]])
        sims = normalize(obj_features) @ text.T
        obj_class = vocab[np.argmax(sims, axis=1)]
    else:
        obj_class = obj_labels
    point_labels = obj_class[object_ids]
    t["labels_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    tree = cKDTree(map_points)
    t["tree_build_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    _, idx = tree.query(gt_xyz, k=1, workers=-1)
    pred = point_labels[idx]
    t["query_s"] = time.perf_counter() - t0

    t0 = time.perf_counter()
    labels = np.append(vocab, -1)  # V is sorted; -1 is the last row/column
    keep = np.isin(gt_labels, vocab)
    gi = np.searchsorted(vocab, gt_labels[keep])
    pi = np.searchsorted(vocab, pred[keep])
    if obj_features is None:  # given labels may lie outside V: count them as -1
        pi[vocab[np.minimum(pi, len(vocab) - 1)] != pred[keep]] = len(vocab)
    n = len(labels)
    matrix = np.bincount(gi * n + pi, minlength=n * n).astype(np.int64).reshape(n, n)
    metrics = compute_metrics(matrix, labels)
    t["confusion_metrics_s"] = time.perf_counter() - t0

    out = {"labels": labels.tolist(), "matrix": matrix.tolist(), "metrics": metrics}
    args.json.write_text(json.dumps(out) + "\n")
    t["total_s"] = time.perf_counter() - t_start
    if args.timings:
        print(json.dumps(t), file=sys.stderr)


if __name__ == "__main__":
    main()
