"""The exporters on small pickles built here in ConceptGraphs' and BBQ's structure, with
stand-ins for the packages they reference (OmegaConf configs, PyTorch tensors saved by
torch.save), which the exporter must read without those packages installed.

    python3 -m unittest discover -s tools/tests

With OSMAB_BIN and OSMAB_TEST_RELEASE set (a built release folder), the exported
submission is also validated with `osmab client validate`.
"""

import gzip
import io
import json
import os
import pickle
import subprocess
import sys
import tempfile
import types
import unittest
import zipfile
from collections import OrderedDict

import numpy as np

sys.path.insert(0, os.path.join(os.path.dirname(__file__), ".."))
import osmab_export  # noqa: E402


def fake_module(name, **members):
    module = types.ModuleType(name)
    for key, value in members.items():
        value.__module__ = name
        value.__qualname__ = key
        setattr(module, key, value)
    sys.modules[name] = module
    return module


class DictConfig:
    """Stands for omegaconf.dictconfig.DictConfig in the pickle."""

    def __init__(self, content):
        self.content = content


class FloatStorage:
    pass


def _rebuild_tensor_v2(*args):
    raise AssertionError("never called while pickling")


def _load_from_bytes(data):
    raise AssertionError("never called while pickling")


fake_module("omegaconf")
fake_module("omegaconf.dictconfig", DictConfig=DictConfig)
fake_module("torch", FloatStorage=FloatStorage)
fake_module("torch._utils", _rebuild_tensor_v2=_rebuild_tensor_v2)
fake_module("torch.storage", _load_from_bytes=_load_from_bytes)


class SavedStorage:
    """A float32 storage as torch.save writes it: a zip of data.pkl and data/0."""

    def __init__(self, values):
        self.values = np.asarray(values, dtype=np.float32)

    def __reduce__(self):
        marker = object()
        buffer = io.BytesIO()

        class Pickler(pickle.Pickler):
            def persistent_id(self, obj):
                return ("storage", FloatStorage, "0", "cpu", len(values)) if obj is marker else None

        values = self.values
        Pickler(buffer, protocol=2).dump(marker)
        archive = io.BytesIO()
        with zipfile.ZipFile(archive, "w") as z:
            z.writestr("archive/data.pkl", buffer.getvalue())
            z.writestr("archive/data/0", values.tobytes())
        return (_load_from_bytes, (archive.getvalue(),))


class Tensor:
    """A 1×D tensor as torch pickles it."""

    def __init__(self, values):
        self.values = np.asarray(values, dtype=np.float32)

    def __reduce__(self):
        d = len(self.values)
        return (_rebuild_tensor_v2, (SavedStorage(self.values), 0, (1, d), (d, 1), False, OrderedDict()))


def objects(rng, count, dim, background=()):
    out = []
    for i in range(count):
        n = 20 + 5 * i
        out.append({
            "pcd_np": rng.normal(size=(n, 3)) + i,
            "pcd_color_np": rng.random((n, 3)),
            "bbox_np": rng.normal(size=(8, 3)),
            "clip_ft": rng.normal(size=dim).astype(np.float32),
            "class_name": ["item"] * 3,
            "is_background": i in background,
            "num_detections": 3,
        })
    return out


class ExportTest(unittest.TestCase):
    def setUp(self):
        self.dir = tempfile.mkdtemp()
        self.rng = np.random.default_rng(3)

    def write_pickle(self, name, data):
        path = os.path.join(self.dir, name)
        with gzip.open(path, "wb") as f:
            pickle.dump(data, f, protocol=4)
        return path

    def test_conceptgraphs_map_and_scene_graph(self):
        objs = objects(self.rng, 4, 16, background=(0,))
        path = self.write_pickle("full_pcd_none_overlap_post.pkl.gz", {"objects": objs, "bg_objects": None, "cfg": DictConfig({"stride": 5}), "class_names": ["item"]})
        nodes = [{"id": i, "bbox_extent": [1.0, 1.0, 1.0], "bbox_center": [0.0, 0.5, float(i)], "possible_tags": ["chair"], "object_tag": "chair", "caption": "a chair"} for i in range(3)]
        graph = os.path.join(self.dir, "scene_graph.json")
        with open(graph, "w") as f:
            json.dump(nodes, f)
        out = os.path.join(self.dir, "sub")
        self.assertEqual(osmab_export.main(["conceptgraphs", "--map", path, "--scene-graph", graph, "--lighting", "baseline", "--scene", "scene_000", "--out", out]), 0)
        with np.load(os.path.join(out, "maps/baseline/scene_000.npz")) as npz:
            foreground = objs[1:]
            self.assertEqual(npz["points"].dtype, np.float32)
            self.assertEqual(len(npz["points"]), sum(len(o["pcd_np"]) for o in foreground), "background objects are left out")
            np.testing.assert_allclose(npz["points"][: len(foreground[0]["pcd_np"])], foreground[0]["pcd_np"].astype(np.float32))
            self.assertEqual(npz["features"].shape, (3, 16))
            np.testing.assert_array_equal(npz["features"][2], foreground[2]["clip_ft"])
            self.assertEqual(sorted(set(npz["object_ids"].tolist())), [0, 1, 2])
        with open(os.path.join(out, "graphs/baseline/scene_000.json")) as f:
            self.assertEqual(json.load(f), nodes)

    def test_bbq_map_with_torch_tensors(self):
        objs = objects(self.rng, 3, 8)
        for o in objs:
            o["clip_ft"] = Tensor(o["clip_ft"])
        path = self.write_pickle("baseline_scene_001_with_feats.pkl.gz", {"objects": objs})
        out = os.path.join(self.dir, "sub")
        self.assertEqual(osmab_export.main(["bbq", "--map", path, "--lighting", "camera", "--scene", "scene_001", "--out", out]), 0)
        with np.load(os.path.join(out, "maps/camera/scene_001.npz")) as npz:
            self.assertEqual(npz["features"].shape, (3, 8))
            np.testing.assert_array_equal(npz["features"][1], objs[1]["clip_ft"].values)

    def test_bad_maps_are_refused_with_a_reason(self):
        out = os.path.join(self.dir, "sub")
        missing = self.write_pickle("bbq.pkl.gz", {"objects": [{"pcd_np": np.zeros((3, 3))}]})
        nan = objects(self.rng, 2, 4)
        nan[1]["pcd_np"][0, 0] = np.nan
        nan_path = self.write_pickle("cg.pkl.gz", {"objects": nan})
        for argv, reason in (
            (["bbq", "--map", missing, "--lighting", "baseline", "--scene", "s", "--out", out], "has no 'clip_ft'"),
            (["conceptgraphs", "--map", nan_path, "--lighting", "baseline", "--scene", "s", "--out", out], "NaN"),
        ):
            stderr = io.StringIO()
            old, sys.stderr = sys.stderr, stderr
            try:
                self.assertEqual(osmab_export.main(argv), 1)
            finally:
                sys.stderr = old
            self.assertIn(reason, stderr.getvalue())

    @unittest.skipUnless(os.environ.get("OSMAB_BIN") and os.environ.get("OSMAB_TEST_RELEASE"), "needs OSMAB_BIN and OSMAB_TEST_RELEASE")
    def test_an_exported_submission_validates(self):
        release = os.environ["OSMAB_TEST_RELEASE"]
        with open(os.path.join(release, "manifest.json")) as f:
            manifest = json.load(f)
        with open(os.path.join(release, "classes.json")) as f:
            classes = json.load(f)["classes"]
        out = os.path.join(self.dir, "sub")
        self.assertEqual(osmab_export.main(["init", "--out", out, "--release", manifest["version"], "--method", "exported"]), 0)
        embeddings = os.path.join(self.dir, "emb.npy")
        np.save(embeddings, np.eye(len(classes), 16, dtype=np.float32) + 0.01)
        self.assertEqual(osmab_export.main(["text-features", "--classes", os.path.join(release, "classes.json"), "--embeddings", embeddings, "--out", out]), 0)
        scene = manifest["scenes"][0]["id"]
        objs = objects(self.rng, 3, 16)
        for o in objs:  # inside the scene's extent
            o["pcd_np"] = self.rng.uniform(-1.0, 1.0, size=(50, 3)) + [0.0, 1.0, 0.0]
        path = self.write_pickle("cg.pkl.gz", {"objects": objs})
        self.assertEqual(osmab_export.main(["conceptgraphs", "--map", path, "--lighting", "baseline", "--scene", scene, "--out", out]), 0)
        done = subprocess.run([os.environ["OSMAB_BIN"], "client", "validate", out, "--release-dir", release], capture_output=True, text=True)
        self.assertEqual(done.returncode, 0, done.stdout + done.stderr)
        self.assertIn("Valid for release", done.stdout)


if __name__ == "__main__":
    unittest.main()
