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
import pickletools
import re
import struct
import subprocess
import sys
import tempfile
import types
import unittest
import zipfile
from collections import OrderedDict

import numpy as np

EXPORTER = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "osmab_export.py")
sys.path.insert(0, os.path.dirname(EXPORTER))
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


class DoubleStorage:
    pass


class BFloat16Storage:
    pass


def _rebuild_tensor_v2(*args):
    raise AssertionError("never called while pickling")


def _load_from_bytes(data):
    raise AssertionError("never called while pickling")


fake_module("omegaconf")
fake_module("omegaconf.dictconfig", DictConfig=DictConfig)
fake_module("torch", FloatStorage=FloatStorage, DoubleStorage=DoubleStorage, BFloat16Storage=BFloat16Storage)
fake_module("torch._utils", _rebuild_tensor_v2=_rebuild_tensor_v2)
fake_module("torch.storage", _load_from_bytes=_load_from_bytes)


class SavedStorage:
    """A float32 storage as torch.save writes it: a zip of data.pkl and data/0 (numel: what data.pkl claims)."""

    def __init__(self, values, numel=None):
        self.values = np.asarray(values, dtype=np.float32)
        self.numel = len(self.values) if numel is None else numel

    def __reduce__(self):
        marker = object()
        buffer = io.BytesIO()
        numel = self.numel

        class Pickler(pickle.Pickler):
            def persistent_id(self, obj):
                return ("storage", FloatStorage, "0", "cpu", numel) if obj is marker else None

        values = self.values
        Pickler(buffer, protocol=2).dump(marker)
        archive = io.BytesIO()
        with zipfile.ZipFile(archive, "w") as z:
            z.writestr("archive/data.pkl", buffer.getvalue())
            z.writestr("archive/data/0", values.tobytes())
        return (_load_from_bytes, (archive.getvalue(),))


TORCH_MAGIC = 0x1950A86A20F9469CFC6C


def torch_legacy_bytes(values, storage_type=FloatStorage, key="94655030452864", location="cpu", view_metadata=None,
                       numel=None, count=None, cut=0):
    """What torch.save(storage, f, _use_new_zipfile_serialization=False) writes, which is what a torch storage's
    __reduce__ hands to torch.storage._load_from_bytes (torch/serialization.py _legacy_save, _legacy_load):

        pickle (protocol 2) of the magic number 0x1950a86a20f9469cfc6c
        pickle of the protocol version 1001
        pickle of sys_info {protocol_version, little_endian, type_sizes {short, int, long}}
        the main pickle: the storage as persistent id ('storage', storage_type, key, location, numel, view_metadata)
        pickle of the sorted storage keys
        per key: the element count as 8 bytes little-endian, then the elements' bytes, little-endian

    numel and count override the element counts the pickle and the data record claim; cut drops bytes at the end."""
    values = np.asarray(values)
    values = values.astype(values.dtype.newbyteorder("<"))
    out = io.BytesIO()
    pickle.dump(TORCH_MAGIC, out, protocol=2)
    pickle.dump(1001, out, protocol=2)
    pickle.dump({"protocol_version": 1001, "little_endian": True, "type_sizes": {"short": 2, "int": 4, "long": 8}}, out, protocol=2)
    marker = object()
    pid = ("storage", storage_type, key, location, len(values) if numel is None else numel, view_metadata)

    class Pickler(pickle.Pickler):
        def persistent_id(self, obj):
            return pid if obj is marker else None

    Pickler(out, protocol=2).dump(marker)
    pickle.dump([key], out, protocol=2)
    out.write(struct.pack("<q", len(values) if count is None else count))
    out.write(values.tobytes())
    data = out.getvalue()
    return data[: len(data) - cut]


class LegacyStorage:
    """A storage as a torch storage pickles itself: _load_from_bytes of the legacy torch.save stream."""

    def __init__(self, values, **kwargs):
        self.data = torch_legacy_bytes(values, **kwargs)

    def __reduce__(self):
        return (_load_from_bytes, (self.data,))


class Tensor:
    """A tensor as torch pickles it: _rebuild_tensor_v2(storage, offset, size, stride, requires_grad, hooks);
    by default a 1×D view of a zip-format float32 storage."""

    def __init__(self, values, storage=None, offset=0, size=None, stride=None):
        self.values = np.asarray(values, dtype=np.float32)
        d = len(self.values)
        self.storage = SavedStorage(self.values) if storage is None else storage
        self.args = (offset, (1, d) if size is None else size, (d, 1) if stride is None else stride)

    def __reduce__(self):
        return (_rebuild_tensor_v2, (self.storage, *self.args, False, OrderedDict()))


class Reduce:
    """Pickles as func(*args) (then state, if given): for crafting pickles NumPy or Python would never write."""

    def __init__(self, func, args, state=None):
        self.func, self.args, self.state = func, args, state

    def __reduce__(self):
        return (self.func, self.args) if self.state is None else (self.func, self.args, self.state)


def with_numpy_core(data, core):
    """The pickle data with every numpy.core / numpy._core module it names renamed to core (protocol 2 GLOBAL
    text, protocol 4+ strings for STACK_GLOBAL; frames, which are optional, are dropped)."""
    ops = list(pickletools.genops(data))
    out = bytearray()
    for i, (op, arg, pos) in enumerate(ops):
        chunk = data[pos: ops[i + 1][2] if i + 1 < len(ops) else len(data)]
        if op.name == "FRAME":
            continue
        if isinstance(arg, str) and re.match(r"numpy\._?core(\.| |$)", arg):
            new = re.sub(r"^numpy\._?core", core, arg).encode()
            if op.name == "GLOBAL":
                chunk = b"c" + new.replace(b" ", b"\n", 1) + b"\n"
            elif op.name == "SHORT_BINUNICODE":
                chunk = b"\x8c" + bytes([len(new)]) + new
            elif op.name == "BINUNICODE":
                chunk = b"X" + struct.pack("<I", len(new)) + new
            else:
                raise AssertionError(f"unexpected {op.name} naming {arg}")
        out += chunk
    return bytes(out)


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

    def export(self, command, path, out=None):
        out = out or os.path.join(self.dir, "sub")
        self.assertEqual(osmab_export.main([command, "--map", path, "--lighting", "baseline", "--scene", "s", "--out", out]), 0)
        return np.load(os.path.join(out, "maps/baseline/s.npz"))

    def run_exporter(self, command, path):
        """The exporter as participants run it, in its own process (a crash there fails the test, not the run)."""
        env = {k: v for k, v in os.environ.items() if k != "OSMAB_EXPORT_DEBUG"}
        return subprocess.run([sys.executable, EXPORTER, command, "--map", path, "--lighting", "baseline", "--scene", "s",
                               "--out", os.path.join(self.dir, "sub")], capture_output=True, text=True, env=env, timeout=300)

    def assert_refused(self, done, *words):
        """Exit status 1 and exactly one line on stderr (no traceback) holding every word."""
        self.assertEqual(done.returncode, 1, f"exit status {done.returncode}; stderr: {done.stderr}")
        self.assertNotIn("Traceback", done.stderr)
        lines = done.stderr.splitlines()
        self.assertEqual(len(lines), 1, done.stderr)
        self.assertTrue(lines[0].startswith("osmab_export: "), lines[0])
        for word in words:
            self.assertIn(word, lines[0])

    def test_bbq_map_with_legacy_torch_storages(self):
        d = 8
        base = self.rng.normal(size=(4, d)).astype(np.float32)
        first = LegacyStorage(base[0]).data
        header = b"\x80\x02\x8a\x0a" + TORCH_MAGIC.to_bytes(10, "little") + b"." + b"\x80\x02M\xe9\x03."
        self.assertTrue(first.startswith(header), "the magic number, then protocol version 1001, pickled with protocol 2")
        self.assertTrue(first.endswith(struct.pack("<q", d) + base[0].tobytes()), "element count, then the elements")
        objs = objects(self.rng, 5, d)
        # a 1×D tensor over a storage of its own, as BBQ's pickled CLIP features are
        objs[0]["clip_ft"] = Tensor(base[0], storage=LegacyStorage(base[0]))
        # every other element from element 3: offset 3, size (D,), stride (2,)
        wide = self.rng.normal(size=3 + 2 * d).astype(np.float32)
        objs[1]["clip_ft"] = Tensor(wide, storage=LegacyStorage(wide), offset=3, size=(d,), stride=(2,))
        # float64 storages; the points as a transposed (N, 3) view, stride (1, N)
        xyz = self.rng.normal(size=(3, 30))
        objs[2]["pcd_np"] = Tensor(xyz[0], storage=LegacyStorage(xyz.reshape(-1), storage_type=DoubleStorage), size=(30, 3), stride=(1, 30))
        objs[2]["clip_ft"] = Tensor(base[2], storage=LegacyStorage(base[2].astype(np.float64), storage_type=DoubleStorage), size=(d,), stride=(1,))
        # a storage view (the legacy view_metadata): elements d to 2d of its root storage
        root = np.concatenate([base[3] + 100, base[3]])
        objs[3]["clip_ft"] = Tensor(base[3], storage=LegacyStorage(root, view_metadata=("94655030453000", d, d)), size=(d,), stride=(1,))
        # bfloat16: the upper half of a float32
        bf16 = (base[1].view(np.uint32) >> 16).astype(np.uint16)
        objs[4]["clip_ft"] = Tensor(base[1], storage=LegacyStorage(bf16, storage_type=BFloat16Storage), size=(d,), stride=(1,))
        path = self.write_pickle("baseline_scene_002_with_feats.pkl.gz", {"objects": objs})
        with self.export("bbq", path) as npz:
            expected = [base[0], wide[3::2], base[2], base[3], (bf16.astype(np.uint32) << 16).view(np.float32)]
            np.testing.assert_array_equal(npz["features"], np.stack(expected))
            offset = sum(len(o["pcd_np"]) for o in objs[:2])
            np.testing.assert_array_equal(npz["points"][offset: offset + 30], xyz.T.astype(np.float32))

    def test_tensor_views_are_checked_against_their_storage(self):
        values = np.arange(12, dtype=np.float32)
        cases = [
            (dict(offset=1000, size=(1,), stride=(1,)), "view reaches element 1000 of a 12-element storage"),
            (dict(size=(1, 100), stride=(100, 1)), "view reaches element 99 of a 12-element storage"),
            (dict(size=(4,), stride=(10 ** 12,)), "view reaches element 3000000000000 of a 12-element storage"),
            (dict(size=(-1, 4), stride=(4, 1)), "negative size"),
            (dict(offset=11, size=(4,), stride=(-1,)), "negative stride"),
            (dict(offset=-4, size=(4,), stride=(1,)), "negative storage offset"),
            (dict(size=(10 ** 6, 10 ** 6), stride=(0, 0)), "more than the"),
            (dict(size=(4,), stride=(1, 1)), "different lengths"),
            (dict(size="abc", stride=(1,)), "must be a tuple of integers"),
        ]
        for storage in (SavedStorage(values), LegacyStorage(values)):
            for i, (view, reason) in enumerate(cases):
                with self.subTest(storage=type(storage).__name__, view=view):
                    objs = objects(self.rng, 2, 4)
                    objs[1]["clip_ft"] = Tensor(values, storage=storage, **view)
                    path = self.write_pickle(f"view{i}.pkl.gz", {"objects": objs})
                    self.assert_refused(self.run_exporter("bbq", path), path, "object 1: tensor 'clip_ft' (storage ", reason)
        # storages whose data is not what their pickle claims
        for name, storage, reason in (
            ("zip-short", SavedStorage(values[:8], numel=12), "12 FloatStorage elements need 48 bytes, the file holds 32"),
            ("legacy-cut", LegacyStorage(values, cut=8), "12 FloatStorage elements need 48 bytes, the file holds 40"),
            ("legacy-count", LegacyStorage(values, count=100), "the data holds 100 elements, the pickle says 12"),
            ("legacy-view", LegacyStorage(values, view_metadata=("1", 8, 8)), "elements 8 to 16 of a 12-element storage"),
        ):
            with self.subTest(storage=name):
                objs = objects(self.rng, 2, 12)  # consistent but for the storage: reading past its data would pass
                objs[1]["clip_ft"] = Tensor(values, storage=storage, size=(1, 12), stride=(12, 1))
                path = self.write_pickle(f"{name}.pkl.gz", {"objects": objs})
                self.assert_refused(self.run_exporter("bbq", path), path, reason)

    def test_malformed_inputs_end_in_one_error_line(self):
        reconstruct = np.zeros(1).__reduce__()[0]  # numpy's _reconstruct, whichever module holds it
        marker = os.path.join(self.dir, "marker")
        good = self.write_pickle("good.pkl.gz", {"objects": objects(self.rng, 2, 4)})
        with open(good, "rb") as f:
            good_bytes = f.read()

        def raw(name, data):
            path = os.path.join(self.dir, name)
            with open(path, "wb") as f:
                f.write(data)
            return path

        def with_pcd(name, pcd):
            objs = objects(self.rng, 2, 4)
            objs[1]["pcd_np"] = pcd
            return self.write_pickle(name, {"objects": objs})

        cases = [
            ("truncated gzip", raw("cut.pkl.gz", good_bytes[: len(good_bytes) // 2]), "ends early"),
            ("not gzip", raw("text.pkl.gz", b"this is not a map\n"), "not a gzip file"),
            ("garbage", raw("garbage.pkl", b"\x00\xffgarbage" * 10), "not a readable pickle"),
            ("missing", os.path.join(self.dir, "missing.pkl.gz"), "No such file"),
            ("objects not a list", self.write_pickle("o.pkl.gz", {"objects": 3}), "not a ConceptGraphs map"),
            ("points as text", with_pcd("s.pkl.gz", "abc"), "object 1: pcd_np: expected numbers"),
            ("ragged points", with_pcd("r.pkl.gz", [[1.0, 2.0, 3.0], [1.0]]), "object 1: pcd_np: not an array of numbers"),
            ("beyond float32", with_pcd("f.pkl.gz", np.full((4, 3), 1e300)), "beyond float32"),
            ("huge array shape", with_pcd("h.pkl.gz", Reduce(reconstruct, (np.ndarray, (0,), b"b"), (1, (10 ** 6, 10 ** 6), np.dtype("f4"), False, b""))), "more than the"),
            ("negative array shape", with_pcd("n.pkl.gz", Reduce(reconstruct, (np.ndarray, (0,), b"b"), (1, (-1, 3), np.dtype("f4"), False, b""))), "negative size"),
            ("short array data", with_pcd("d.pkl.gz", Reduce(reconstruct, (np.ndarray, (0,), b"b"), (1, (4, 3), np.dtype("f4"), False, b"\0" * 8))), "needs 48 bytes, the pickle holds 8"),
            ("array without data", with_pcd("u.pkl.gz", Reduce(np.ndarray, ((100, 3),))), "numpy.ndarray directly"),
            ("other codec", with_pcd("c.pkl.gz", Reduce(__import__("codecs").encode, ("abc", "rot13"))), "_codecs.encode"),
            ("huge bytearray", with_pcd("b.pkl.gz", Reduce(bytearray, (10 ** 12,))), "bytearray of 1000000000000 bytes"),
            ("garbage storage", with_pcd("g.pkl.gz", Tensor(np.zeros(3), storage=Reduce(_load_from_bytes, (b"garbage",)))), "unknown format"),
            ("hostile global", self.write_pickle("x.pkl.gz", {"objects": Reduce(os.system, (f"touch {marker}",))}), "not a ConceptGraphs map"),
        ]
        for what, path, reason in cases:
            with self.subTest(what):
                self.assert_refused(self.run_exporter("conceptgraphs", path), os.path.basename(path), reason)
        self.assertFalse(os.path.exists(marker), "a global the pickle names is never called")
        self.assert_refused(self.run_exporter("bbq", self.write_pickle("l.pkl.gz", [1, 2])), "object 0 is int, not a dict")

    def test_protocol_2_pickles_written_by_python_3(self):
        objs = objects(self.rng, 3, 16)
        objs[0]["pcd_np"] = np.zeros((0, 3))  # bytes() for its empty data
        for o in objs:
            o["conf"] = np.float32(0.5)
            o["tags"] = {"chair", "table"}
        data = pickle.dumps({"objects": objs, "meta": OrderedDict(stride=5), "cfg": DictConfig({"stride": 5})}, protocol=2)
        self.assertIn(b"c_codecs\nencode\n", data, "Python 3 writes bytes as _codecs.encode(text, 'latin1') in protocol 2")
        self.assertIn(b"c__builtin__\nset\n", data)
        path = os.path.join(self.dir, "p2.pkl.gz")
        with gzip.open(path, "wb") as f:
            f.write(data)
        with self.export("conceptgraphs", path) as npz:
            self.assertEqual(len(npz["points"]), sum(len(o["pcd_np"]) for o in objs))
            np.testing.assert_array_equal(npz["features"], np.stack([o["clip_ft"] for o in objs[1:]]))
            np.testing.assert_array_equal(npz["points"][:25], objs[1]["pcd_np"].astype(np.float32))

    def test_numpy_1_and_2_module_names_both_load(self):
        installed = "numpy._core" if osmab_export._NUMPY_2 else "numpy.core"
        for name in ("numpy.core.multiarray", "numpy._core.multiarray", "numpy.core.numeric", "numpy._core.numeric", "numpy"):
            self.assertEqual(osmab_export.numpy_module(name), re.sub(r"^numpy\._?core", installed, name))
        objs = objects(self.rng, 2, 8)
        objs[1]["pcd_np"] = np.asfortranarray(objs[1]["pcd_np"])[:, [2, 1, 0]]  # not contiguous: _reconstruct
        for o in objs:
            o["conf"] = np.float64(0.25)  # scalar
        for protocol in (2, 5):  # 5: contiguous arrays through numeric._frombuffer
            data = pickle.dumps({"objects": objs}, protocol=protocol)
            for core in ("numpy.core", "numpy._core"):
                with self.subTest(protocol=protocol, names=core):
                    crafted = with_numpy_core(data, core)
                    self.assertIn(f"{core}.multiarray".encode(), crafted)
                    if protocol == 5:
                        self.assertIn(f"{core}.numeric".encode(), crafted)
                    other = "numpy.core." if core == "numpy._core" else "numpy._core."
                    self.assertNotIn(other.encode(), crafted)
                    path = os.path.join(self.dir, f"np{protocol}{core}.pkl.gz")
                    with gzip.open(path, "wb") as f:
                        f.write(crafted)
                    with self.export("conceptgraphs", path, os.path.join(self.dir, f"sub{protocol}{core}")) as npz:
                        np.testing.assert_array_equal(npz["points"], np.concatenate([o["pcd_np"] for o in objs]).astype(np.float32))
                        np.testing.assert_array_equal(npz["features"], np.stack([o["clip_ft"] for o in objs]))

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
        self.assertIn("Valid for the val split of release", done.stdout)


if __name__ == "__main__":
    unittest.main()


class WithoutNumPy(unittest.TestCase):
    def test_help_without_numpy_says_what_to_install_instead_of_a_traceback(self):
        # A Python where `import numpy` fails, as on a machine without it.
        script = "import runpy, sys; sys.modules['numpy'] = None; sys.argv = ['osmab_export.py', '--help']; runpy.run_path(%r, run_name='__main__')" % EXPORTER
        done = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True)
        self.assertEqual(done.returncode, 1, done.stderr)
        self.assertIn("needs NumPy", done.stderr)
        self.assertIn("pip install numpy", done.stderr)
        self.assertNotIn("Traceback", done.stderr)
