#!/usr/bin/env python3
"""Turn ConceptGraphs and BBQ outputs into an OSMa-Bench++ submission (docs/participants.md).

Needs Python 3.9+ and NumPy (1.x or 2.x) only: the pickles are read with a restricted unpickler that
rebuilds NumPy arrays (and PyTorch tensors, from the bytes torch.save wrote in its zip or its legacy
format) and stands in for every other class (OmegaConf configs, ConceptGraphs' own types), so neither
ConceptGraphs, BBQ, PyTorch nor OmegaConf has to be installed. Every array and tensor is checked against
the bytes the file holds before it is read; a malformed file ends in one error line on stderr and exit
status 1 (OSMAB_EXPORT_DEBUG=1 shows the traceback of an unexpected error).

Installed with the client (`pip install osmab-client`) it is the command `osmab-export`; from the
repository, `python3 tools/osmab_export.py`:

    osmab-export init --out SUB --release demo-2 --method "ConceptGraphs (ours)"
    osmab-export conceptgraphs --map full_pcd_..._post.pkl.gz \\
        --scene-graph sg_cache/scene_graph.json --lighting baseline --scene scene_000 --out SUB
    osmab-export bbq --map baseline_scene_000_with_feats.pkl.gz \\
        --nodes nodes.json --lighting baseline --scene scene_000 --out SUB
    osmab-export text-features --classes release/classes.json --embeddings emb.npy --out SUB

Maps are written as maps/<lighting>/<scene>.npz (points float32 in the release's world frame,
object_ids int64, per-object features float32 or labels int64); scene graphs as
graphs/<lighting>/<scene>.json. Background objects (walls, floor, ceiling) are left out, as the
OSMa-Bench adaptors leave them out.
"""

import argparse
import builtins
import collections
import contextlib
import gzip
import importlib
import io
import json
import os
import pickle
import pickletools
import re
import sys
import zipfile
import zlib

try:
    import numpy as np
except ImportError:  # --help and every command need it; say so instead of a traceback
    sys.exit(
        "osmab_export.py needs NumPy (the only package it uses): pip install numpy\n"
        f"(this Python is {sys.executable}; install it into the environment that runs the exporter)"
    )

# ---------------------------------------------------------------- reading pickles without their packages
#
# Nothing a pickle says is trusted: every global it names is looked up in the short list below (anything else
# becomes a Stand_in), NumPy arrays, dtypes and scalars are rebuilt by the checked functions here rather than
# NumPy's own, and a tensor is only read out of its storage once its size, stride and offset have been checked
# against the storage (see _TensorRef.to_array). A malformed file ends in an ExportError, never in a view of
# memory the file did not provide.


class ExportError(Exception):
    """A refusal, with the reason in one line."""


MAX_ELEMENTS = 1 << 28  # per array or tensor; a ConceptGraphs or BBQ map is far below it
MAX_STORAGE_BYTES = 1 << 32  # per torch storage
MAX_CONTAINER = 1 << 24  # what a builtin (bytearray(n), list(range(n))) may be asked to allocate
MAX_NDIM = 32


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


class _Unreadable(Stand_in):
    """A NumPy value of a kind the exporter does not read (structured or datetime dtypes): an error if used."""

    def __init__(self, reason):
        self.reason = reason


def _shorten(value, limit=60):
    text = repr(value)
    return text if len(text) <= limit else text[: limit - 3] + "..."


def _int(value, what):
    if isinstance(value, bool) or not isinstance(value, (int, np.integer)):
        raise ExportError(f"{what} must be an integer, found {_shorten(value)}")
    return int(value)


def _ints(value, what):
    if not isinstance(value, (tuple, list)):
        raise ExportError(f"{what} must be a tuple of integers, found {_shorten(value)}")
    if len(value) > MAX_NDIM:
        raise ExportError(f"{what} has {len(value)} dimensions (at most {MAX_NDIM})")
    return tuple(_int(v, what) for v in value)


def _shape(value, what):
    """A shape: non-negative integers whose product is at most MAX_ELEMENTS; returns (shape, element count)."""
    shape = _ints(value, what)
    if any(n < 0 for n in shape):
        raise ExportError(f"{what} {shape}: negative size")
    count = 1
    for n in shape:
        count *= n
    if count > MAX_ELEMENTS:
        raise ExportError(f"{what} {shape} has {count} elements, more than the {MAX_ELEMENTS} the exporter reads")
    return shape, count


def _raw_bytes(value, what):
    if isinstance(value, (bytes, bytearray)):
        return bytes(value)
    if isinstance(value, pickle.PickleBuffer):
        return value.raw().tobytes()
    if isinstance(value, str):  # NumPy accepts the latin-1 text older pickles hold
        return value.encode("latin1")
    raise ExportError(f"{what} must be bytes, found {type(value).__name__}")


# -- NumPy: arrays, dtypes and scalars rebuilt from the values NumPy pickles, each checked first

_DTYPE_SPEC = re.compile(r"([biufcOSU])([0-9]{1,9})\Z")


class _DTypeSpec:
    """numpy.dtype(spec, align, copy) as a pickle calls it, resolved once its state (byte order, ...) is set."""

    def __init__(self, spec=None, align=False, copy=False):
        self.spec = spec
        self.state = None
        self._resolved = None

    def __setstate__(self, state):
        self.state = state

    def resolve(self):
        """The np.dtype; raises _UnsupportedDtype for dtypes the exporter does not read."""
        if self._resolved is None:
            self._resolved = self._resolve()
        return self._resolved

    def _resolve(self):
        spec = self.spec.decode("ascii", "replace") if isinstance(self.spec, bytes) else self.spec
        match = _DTYPE_SPEC.match(spec) if isinstance(spec, str) else None
        if match is None:
            raise _UnsupportedDtype(f"NumPy dtype {_shorten(spec)}")
        kind, digits = match.group(1), int(match.group(2))
        endian, size = "|", None
        if self.state is not None:
            state = self.state
            if not isinstance(state, tuple) or len(state) < 8:
                raise ExportError(f"NumPy dtype {spec}: malformed state {_shorten(state)}")
            if any(part is not None for part in state[2:5]):
                raise _UnsupportedDtype(f"structured or sub-array NumPy dtype {spec}")
            endian = state[1].decode("ascii", "replace") if isinstance(state[1], bytes) else state[1]
            if endian not in ("<", ">", "|", "="):
                raise ExportError(f"NumPy dtype {spec}: byte order {_shorten(endian)}")
            size = _int(state[5], f"NumPy dtype {spec}: item size")
        if kind == "O":
            dtype = np.dtype("O")  # O8 here, O4 from a 32-bit machine
        elif kind in "SU":
            chars = digits if size is None or size < 0 else size // (4 if kind == "U" else 1)
            if chars > 1 << 20:
                raise ExportError(f"NumPy dtype {spec}: {chars} characters per item")
            dtype = np.dtype(f"{kind}{chars}")
        else:
            try:
                dtype = np.dtype(spec)
            except TypeError:
                raise ExportError(f"NumPy dtype {_shorten(spec)} does not exist") from None
            if dtype.kind != kind:
                raise ExportError(f"NumPy dtype {_shorten(spec)} does not exist")
        if endian in "<>" and dtype.kind != "O":
            dtype = dtype.newbyteorder(endian)
        return dtype


class _UnsupportedDtype(Exception):
    pass


def _dtype_of(value, what):
    if isinstance(value, _DTypeSpec):
        return value.resolve()
    if isinstance(value, np.dtype):
        return value
    raise ExportError(f"{what}: {_shorten(value)} is not a NumPy dtype")


class _CheckedArray(np.ndarray):
    """An ndarray whose pickled state (shape, dtype, data) is checked before NumPy applies it."""

    def __setstate__(self, state):
        if not isinstance(state, tuple) or len(state) not in (4, 5):
            raise ExportError(f"NumPy array: malformed state {_shorten(state)}")
        shape, dtype, fortran, raw = state[-4:]
        shape, count = _shape(shape, "NumPy array shape")
        try:
            dtype = _dtype_of(dtype, "NumPy array")
        except _UnsupportedDtype as e:
            self.unreadable = f"holds a {e} the exporter does not read"
            return
        if dtype.kind == "O":
            if not isinstance(raw, list) or len(raw) != count:
                raise ExportError(f"NumPy object array of shape {shape}: expected a list of {count} items")
        else:
            raw = _raw_bytes(raw, "NumPy array data")
            if len(raw) != count * dtype.itemsize:
                raise ExportError(f"NumPy array of shape {shape} and dtype {dtype} needs {count * dtype.itemsize} bytes, "
                                  f"the pickle holds {len(raw)}")
        np.ndarray.__setstate__(self, (1, shape, dtype, bool(fortran), raw))


class _NDArrayName:
    """numpy.ndarray as a pickle names it: only the first argument of _reconstruct, never called."""

    def __call__(self, *args, **kwargs):
        raise ExportError("the pickle calls numpy.ndarray directly, which NumPy's own pickles never do")


_NDARRAY = _NDArrayName()


def _np_reconstruct(subtype, shape, dtype=None):
    """numpy.core.multiarray._reconstruct: an empty array that the pickle's state then fills."""
    if subtype is not _NDARRAY:
        raise ExportError(f"the pickle rebuilds a NumPy array of type {_shorten(subtype)}, not numpy.ndarray")
    shape, count = _shape(shape, "NumPy array shape")
    if count != 0:
        raise ExportError(f"the pickle creates a NumPy array of shape {shape} without its data")
    return _CheckedArray(shape=shape, dtype=np.uint8)


def _np_frombuffer(buffer, dtype, shape, order="C"):
    """numpy.core.numeric._frombuffer (protocol-5 pickles)."""
    try:
        dtype = _dtype_of(dtype, "NumPy array")
    except _UnsupportedDtype as e:
        return _Unreadable(f"holds a {e} the exporter does not read")
    shape, count = _shape(shape, "NumPy array shape")
    raw = _raw_bytes(buffer, "NumPy array data")
    if dtype.kind == "O" or order not in ("C", "F", "A", "K"):
        raise ExportError(f"NumPy array of dtype {dtype} and order {_shorten(order)} cannot come from a buffer")
    if len(raw) != count * dtype.itemsize:
        raise ExportError(f"NumPy array of shape {shape} and dtype {dtype} needs {count * dtype.itemsize} bytes, "
                          f"the pickle holds {len(raw)}")
    if count == 0:
        return np.zeros(shape, dtype)
    return np.frombuffer(raw, dtype=dtype).reshape(shape, order="F" if order == "F" else "C")


def _np_scalar(dtype, data=None):
    """numpy.core.multiarray.scalar."""
    try:
        dtype = _dtype_of(dtype, "NumPy scalar")
    except _UnsupportedDtype as e:
        return _Unreadable(f"holds a {e} the exporter does not read")
    if dtype.kind == "O":
        return data
    raw = _raw_bytes(data, "NumPy scalar data")
    if len(raw) != dtype.itemsize:
        raise ExportError(f"NumPy scalar of dtype {dtype} needs {dtype.itemsize} bytes, the pickle holds {len(raw)}")
    return np.frombuffer(raw, dtype=dtype)[0] if dtype.itemsize else np.zeros((), dtype)[()]


_NUMPY_GLOBALS = {
    "_reconstruct": _np_reconstruct, "scalar": _np_scalar, "_frombuffer": _np_frombuffer,
    "ndarray": _NDARRAY, "dtype": _DTypeSpec,
}
_NUMPY_MODULES = {"numpy", "numpy.core.multiarray", "numpy.core.numeric", "numpy.core._multiarray_umath"}
_NUMPY_2 = int(np.__version__.split(".")[0]) >= 2


def numpy_module(module):
    """The installed NumPy's name for a module a pickle names: NumPy 2 pickles say numpy._core, NumPy 1 pickles
    numpy.core; each NumPy reads both."""
    if _NUMPY_2 and (module == "numpy.core" or module.startswith("numpy.core.")):
        return "numpy._core" + module[len("numpy.core"):]
    if not _NUMPY_2 and (module == "numpy._core" or module.startswith("numpy._core.")):
        return "numpy.core" + module[len("numpy._core"):]
    return module


def _numpy_global(module, name):
    if module.replace("numpy._core", "numpy.core", 1) not in _NUMPY_MODULES or name not in _NUMPY_GLOBALS:
        return Stand_in
    installed = numpy_module(module)
    try:
        found = hasattr(importlib.import_module(installed), name)
    except ImportError:
        found = False
    if not found:
        raise ExportError(f"the pickle names {module}.{name}, which NumPy {np.__version__} does not have (as {installed}.{name})")
    return _NUMPY_GLOBALS[name]


# -- builtins: the types pickles of plain data name, without letting a pickle allocate at will


def _bounded(factory):
    def build(*args):
        for arg in args:
            if isinstance(arg, int) and not isinstance(arg, bool) and factory is bytearray and arg > MAX_CONTAINER:
                raise ExportError(f"the pickle asks for a bytearray of {arg} bytes")
            if isinstance(arg, range):
                try:
                    length = len(arg)
                except OverflowError:
                    length = MAX_CONTAINER + 1
                if length > MAX_CONTAINER and factory is not range:
                    raise ExportError(f"the pickle asks for a {factory.__name__} of {_shorten(arg)}")
        return factory(*args)

    build.__name__ = factory.__name__
    return build


def _codecs_encode(text, encoding="utf-8", errors="strict"):
    """_codecs.encode as Python 3 writes bytes into protocol-2 pickles: encode(str, 'latin1'), nothing else."""
    if not isinstance(text, str) or encoding not in ("latin1", "latin-1") or errors != "strict":
        raise ExportError("the pickle calls _codecs.encode other than as Python 3 encodes bytes (text, 'latin1')")
    return text.encode("latin1")


def _empty_bytes():
    """builtins.bytes() as Python 3 writes an empty bytes object into protocol-2 pickles (no argument)."""
    return b""


_BUILTINS = {name: _bounded(getattr(builtins, name))
             for name in ("set", "frozenset", "slice", "range", "complex", "bytearray", "list", "dict", "tuple")}
_BUILTINS["bytes"] = _empty_bytes


# -- torch: tensors rebuilt from torch.save's zip format and its legacy (pre-1.6) stream

_TORCH_MAGIC = 0x1950A86A20F9469CFC6C
_TORCH_LEGACY_PROTOCOL = 1001

# storage type: (dtype its bytes are read as, conversion to the NumPy array handed on)
_TORCH_STORAGES = {
    "DoubleStorage": ("f8", None), "FloatStorage": ("f4", None), "HalfStorage": ("f2", None),
    "BFloat16Storage": ("u2", lambda a: (a.astype(np.uint32) << 16).view(np.float32)),
    "LongStorage": ("i8", None), "IntStorage": ("i4", None), "ShortStorage": ("i2", None),
    "CharStorage": ("i1", None), "ByteStorage": ("u1", None), "BoolStorage": ("u1", lambda a: a != 0),
    "ComplexFloatStorage": ("c8", None), "ComplexDoubleStorage": ("c16", None), "UntypedStorage": ("u1", None),
}


class _StorageType:
    def __init__(self, name):
        self.name = name


class _Storage:
    """A torch storage: numel elements of one dtype, at element start of its root storage's bytes."""

    def __init__(self, key, name, numel, byteorder="<"):
        if name not in _TORCH_STORAGES:
            raise ExportError(f"torch {name} tensors are not supported; convert them to float32 first")
        code, self.convert = _TORCH_STORAGES[name]
        self.key, self.name, self.numel = key, name, numel
        self.dtype = np.dtype(byteorder + code)
        if numel * self.dtype.itemsize > MAX_STORAGE_BYTES:
            raise ExportError(f"torch storage {key} has {numel} elements, more than the exporter reads")
        self.root, self.start, self.raw = self, 0, None

    def view(self, key, start, numel):
        if start < 0 or numel < 0 or start + numel > self.numel:
            raise ExportError(f"torch storage view {key}: elements {start} to {start + numel} "
                              f"of a {self.numel}-element storage ({self.key})")
        view = _Storage(key, self.name, numel)
        view.dtype, view.root, view.start = self.dtype, self, start
        return view

    def fill(self, raw):
        expected = self.numel * self.dtype.itemsize
        if len(raw) != expected:
            raise ExportError(f"torch storage {self.key}: {self.numel} {self.name} elements need {expected} bytes, "
                              f"the file holds {len(raw)}")
        self.raw = raw


def _storage_from_pid(pid, storages, lengths, byteorder):
    """torch's persistent id ('storage', storage_type, key, location, numel[, view_metadata]) as a _Storage."""
    if not isinstance(pid, tuple) or not pid:
        raise ExportError(f"unexpected torch persistent id {_shorten(pid)}")
    kind = pid[0].decode("ascii", "replace") if isinstance(pid[0], bytes) else pid[0]
    if kind == "module" and len(pid) == 4:  # an nn.Module class the legacy format records: not needed here
        return Stand_in()
    if kind != "storage" or len(pid) not in lengths:
        raise ExportError(f"unexpected torch persistent id {_shorten(pid)}")
    storage_type, key, _location, numel = pid[1:5]
    if not isinstance(storage_type, _StorageType):
        raise ExportError(f"torch storage of type {_shorten(storage_type)}")
    key = key.decode("ascii", "replace") if isinstance(key, bytes) else key
    if not isinstance(key, str):
        raise ExportError(f"torch storage key {_shorten(key)}")
    numel = _int(numel, f"torch storage {key}: size")
    if numel < 0:
        raise ExportError(f"torch storage {key}: negative size {numel}")
    storage = storages.get(key)
    if storage is None:
        storage = storages[key] = _Storage(key, storage_type.name, numel, byteorder)
    elif storage.name != storage_type.name or storage.numel != numel:
        raise ExportError(f"torch storage {key} appears as {storage.numel} {storage.name} elements "
                          f"and as {numel} {storage_type.name} elements")
    view = pid[5] if len(pid) == 6 else None
    if view is None:
        return storage
    if not isinstance(view, tuple) or len(view) != 3:
        raise ExportError(f"torch storage {key}: malformed view {_shorten(view)}")
    view_key = view[0].decode("ascii", "replace") if isinstance(view[0], bytes) else str(view[0])
    return storage.view(view_key, _int(view[1], "torch storage view offset"), _int(view[2], "torch storage view size"))


class _TensorRef:
    """torch._utils._rebuild_tensor_v2(storage, offset, size, stride, ...): read from the storage only when the
    exporter uses it (to_array), after the checks, so every message can name the tensor."""

    def __init__(self, storage, offset, size, stride, *rest):
        self.storage, self.offset, self.size, self.stride = storage, offset, size, stride
        self._array = None

    def to_array(self, label="tensor"):
        if self._array is None:
            storage = self.storage
            key = storage.key if isinstance(storage, _Storage) else "?"
            try:
                self._array = self._read()
            except ExportError as e:
                raise ExportError(f"{label} (storage {key}): {e}") from None
        return self._array

    def __array__(self, dtype=None, copy=None):
        array = self.to_array()
        return array if dtype is None else array.astype(dtype)

    def _read(self):
        storage = self.storage
        if not isinstance(storage, _Storage):
            raise ExportError(f"its storage is {_shorten(storage)}, not a torch storage")
        if storage.root.raw is None:
            raise ExportError("the file holds no data for its storage")
        offset = _int(self.offset, "storage offset")
        size, count = _shape(self.size, "size")
        stride = _ints(self.stride, "stride")
        if len(stride) != len(size):
            raise ExportError(f"size {size} and stride {stride} have different lengths")
        if offset < 0:
            raise ExportError(f"negative storage offset {offset}")
        if any(s < 0 for s in stride):
            raise ExportError(f"negative stride {stride}")
        n, itemsize = storage.numel, storage.dtype.itemsize
        native = storage.dtype.newbyteorder("=")
        if count == 0:
            if offset > n:
                raise ExportError(f"storage offset {offset} is past the end of a {n}-element storage")
            array = np.zeros(size, native)
        else:
            last = offset + sum((s - 1) * st for s, st in zip(size, stride))
            if last >= n:
                raise ExportError(f"view reaches element {last} of a {n}-element storage")
            # in bounds: last < n, every index is >= offset >= 0, and the buffer is exactly the root's bytes
            view = np.ndarray(shape=size, dtype=storage.dtype, buffer=storage.root.raw,
                              offset=(storage.start + offset) * itemsize, strides=tuple(st * itemsize for st in stride))
            array = view.astype(native)  # a contiguous copy in the machine's byte order
        return storage.convert(array) if storage.convert else array


def _load_from_bytes(data):
    """torch.storage._load_from_bytes: the storage torch.save wrote, in its zip or legacy format."""
    if not isinstance(data, (bytes, bytearray)):
        raise ExportError(f"torch storage bytes expected, found {type(data).__name__}")
    data = bytes(data)
    if data.startswith(b"PK\x03\x04"):
        return _load_torch_zip(data)
    if data[:1] == b"\x80":
        return _load_torch_legacy(data)
    if data[257:262] == b"ustar":
        raise ExportError("a torch storage in PyTorch's tar format (before 0.4) is not supported")
    raise ExportError("torch storage bytes in an unknown format")


def _load_torch_zip(data):
    """torch.save's zip (PyTorch >= 1.6): <root>/data.pkl, <root>/data/<key>, <root>/byteorder."""
    archive = zipfile.ZipFile(io.BytesIO(data))
    pkl = next((n for n in archive.namelist() if n.endswith("data.pkl")), None)
    if pkl is None:
        raise ExportError("torch zip without data.pkl")
    root = pkl[: -len("data.pkl")]
    byteorder = "<"
    if f"{root}byteorder" in archive.namelist():
        order = archive.read(f"{root}byteorder")
        if order not in (b"little", b"big"):
            raise ExportError(f"torch zip with byte order {_shorten(order)}")
        byteorder = "<" if order == b"little" else ">"
    storages = {}

    def storage_for(pid):
        storage = _storage_from_pid(pid, storages, (5,), byteorder)
        if isinstance(storage, _Storage) and storage.root.raw is None:
            root_storage, name = storage.root, f"{root}data/{storage.root.key}"
            try:
                info = archive.getinfo(name)
            except KeyError:
                raise ExportError(f"torch zip without {name}") from None
            expected = root_storage.numel * root_storage.dtype.itemsize
            if info.file_size != expected:
                raise ExportError(f"torch storage {root_storage.key}: {root_storage.numel} {root_storage.name} elements "
                                  f"need {expected} bytes, the file holds {info.file_size}")
            root_storage.fill(archive.read(name))
        return storage

    return unpickle(io.BytesIO(archive.read(pkl)), lambda file: _TorchUnpickler(file, storage_for))


def _load_torch_legacy(data):
    """torch.save(..., _use_new_zipfile_serialization=False), which torch storages use when pickled: pickles of
    the magic number, the protocol version and sys_info, the main pickle (storages as persistent ids), the sorted
    list of storage keys, then per key the element count (int64, little-endian) and the bytes (little-endian)."""
    f = io.BytesIO(data)
    if unpickle(f) != _TORCH_MAGIC:
        raise ExportError("torch storage bytes without torch.save's magic number")
    version = unpickle(f)
    if version != _TORCH_LEGACY_PROTOCOL:
        raise ExportError(f"torch.save legacy protocol version {_shorten(version)} is not supported")
    unpickle(f)  # sys_info: the data is little-endian whatever the machine
    storages = {}
    result = unpickle(f, lambda file: _TorchUnpickler(file, lambda pid: _storage_from_pid(pid, storages, (5, 6), "<")))
    keys = unpickle(f)
    if not isinstance(keys, list) or not all(isinstance(k, str) for k in keys):
        raise ExportError(f"torch.save legacy storage keys: {_shorten(keys)}")
    for key in keys:
        storage = storages.get(key)
        if storage is None:
            raise ExportError(f"torch.save legacy data for storage {key}, which the pickle does not use")
        count = f.read(8)
        if len(count) != 8:
            raise ExportError(f"torch storage {key}: the file ends before its data")
        count = int.from_bytes(count, "little", signed=True)
        if count != storage.numel:
            raise ExportError(f"torch storage {key}: the data holds {count} elements, the pickle says {storage.numel}")
        storage.fill(f.read(count * storage.dtype.itemsize))
    missing = sorted(k for k, s in storages.items() if s.raw is None)
    if missing:
        raise ExportError(f"torch storage {missing[0]}: the file holds no data for it")
    return result


class SafeUnpickler(pickle.Unpickler):
    """Rebuilds NumPy arrays and PyTorch tensors with the checked functions above; any other global becomes a
    Stand_in."""

    def find_class(self, module, name):
        module = {"__builtin__": "builtins", "copy_reg": "copyreg"}.get(module, module)  # protocol <= 2
        if module == "numpy" or module.startswith("numpy."):
            return _numpy_global(module, name)
        if module == "builtins" and name in _BUILTINS:
            return _BUILTINS[name]
        if module == "collections" and name in ("OrderedDict", "defaultdict"):
            return getattr(collections, name)
        if module == "_codecs" and name == "encode":
            return _codecs_encode
        if module == "torch._utils" and name == "_rebuild_tensor_v2":
            return _TensorRef
        if module == "torch.storage" and name == "_load_from_bytes":
            return _load_from_bytes
        if module == "torch" and name.endswith("Storage"):
            return _StorageType(name)
        return Stand_in

    def persistent_load(self, pid):
        raise ExportError(f"unexpected persistent id {_shorten(pid)} outside a torch storage")


class _TorchUnpickler(SafeUnpickler):
    def __init__(self, file, storage_for):
        super().__init__(file)
        self._storage_for = storage_for

    def persistent_load(self, pid):
        return self._storage_for(pid)


def unpickle(f, unpickler=SafeUnpickler):
    """The next pickle of the in-memory file f, read with the restricted unpickler once pickletools has walked
    its opcodes: a length the data cannot hold (a corrupt or hostile file) is refused before the unpickler
    would allocate it."""
    start = f.tell()
    try:
        for _ in pickletools.genops(f):
            pass
    except ValueError as e:
        raise ExportError(f"not a readable pickle: {one_line(e, 200)}") from None
    f.seek(start)
    return unpickler(f).load()


def load_pickle(path):
    """A .pkl or .pkl.gz file, read with the restricted unpickler."""
    opener = gzip.open if path.endswith(".gz") else open
    with opener(path, "rb") as f:
        data = f.read()
    return unpickle(io.BytesIO(data))


# ---------------------------------------------------------------- the submission layout


class _Located(ExportError):
    """An ExportError whose message already names the file."""


def one_line(text, limit=500):
    text = " ".join(str(text).split())
    return text if len(text) <= limit else text[: limit - 3] + "..."


def describe(error):
    """The reason an exception gives, in one line (whatever a malformed input made the reading raise)."""
    if isinstance(error, ExportError):
        return one_line(error)
    if isinstance(error, EOFError):
        reason = f"the file ends early (truncated?): {error}"
    elif isinstance(error, gzip.BadGzipFile):
        reason = f"not a gzip file: {error}"
    elif isinstance(error, zlib.error):
        reason = f"corrupt gzip data: {error}"
    elif isinstance(error, json.JSONDecodeError):
        reason = f"not valid JSON: {error}"
    elif isinstance(error, pickle.UnpicklingError):
        reason = f"not a readable pickle: {error}"
    elif isinstance(error, zipfile.BadZipFile):
        reason = f"a torch storage is not a readable zip: {error}"
    elif isinstance(error, MemoryError):
        reason = "too large to load into memory"
    elif isinstance(error, RecursionError):
        reason = "nested too deeply to read"
    elif isinstance(error, OSError):
        reason = str(error)
    elif isinstance(error, KeyError):
        reason = f"missing key {error}"
    else:
        reason = f"malformed input ({type(error).__name__}: {error})"
    return one_line(reason)


@contextlib.contextmanager
def reading(path):
    """Any error while reading or writing path becomes one ExportError naming path (OSMAB_EXPORT_DEBUG=1 keeps
    the traceback)."""
    try:
        yield
    except _Located:
        raise
    except Exception as e:
        if os.environ.get("OSMAB_EXPORT_DEBUG") and not isinstance(e, ExportError):
            raise
        raise _Located(f"{path}: {describe(e)}") from None


def _array(value, where, name=None, ndim=None, cols=None, float32=False):
    """value (a NumPy array, a torch tensor, nested lists of numbers) as a checked array of numbers."""
    label = f"{where}: {name}" if name else where
    if isinstance(value, _TensorRef):
        array = value.to_array(f"{where}: tensor '{name}'" if name else f"{where}: tensor")
    elif isinstance(value, _Unreadable):
        raise ExportError(f"{label}: {value.reason}")
    elif isinstance(value, _CheckedArray) and getattr(value, "unreadable", None):
        raise ExportError(f"{label}: {value.unreadable}")
    else:
        try:
            array = np.asarray(value)
        except (ValueError, TypeError) as e:
            raise ExportError(f"{label}: not an array of numbers ({one_line(e, 120)})") from None
    if array.dtype.kind not in "biuf":
        found = f"{array.dtype} values" if array.ndim else type(value).__name__
        raise ExportError(f"{label}: expected numbers, found {found}")
    if ndim is not None and array.ndim != ndim:
        raise ExportError(f"{label}: expected {ndim} dimensions, found shape {array.shape}")
    if cols is not None and array.shape[-1] != cols:
        raise ExportError(f"{label}: expected {cols} columns, found shape {array.shape}")
    if float32:
        with np.errstate(over="ignore", invalid="ignore"):
            array = array.astype(np.float32)
    if array.dtype.kind == "f" and not np.isfinite(array).all():
        raise ExportError(f"{label}: holds NaN or infinite values" + (" (or values beyond float32)" if float32 else ""))
    return array


def write_map(out, lighting, scene, objects, feature_key):
    """objects: dicts with 'pcd_np' (N, 3) and the feature under feature_key; returns (points, objects)."""
    points, object_ids, features = [], [], []
    for i, obj in enumerate(objects):
        pcd = _array(obj["pcd_np"], f"object {i}", "pcd_np", ndim=2, cols=3, float32=True)
        if len(pcd) == 0:
            continue
        feature = _array(obj[feature_key], f"object {i}", feature_key, float32=True).reshape(-1)
        points.append(pcd)
        object_ids.append(np.full(len(pcd), len(features), dtype=np.int64))
        features.append(feature)
    if not features:
        raise ExportError("the map has no object with points")
    dims = {f.shape[0] for f in features}
    if len(dims) != 1:
        raise ExportError(f"object features have different lengths: {sorted(dims)}")
    path = os.path.join(out, "maps", lighting, f"{scene}.npz")
    with reading(path):
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
    with reading(path):
        os.makedirs(os.path.dirname(path), exist_ok=True)
        with open(path, "w") as f:
            json.dump(nodes, f)
    return len(nodes)


def conceptgraphs_objects(data):
    """The foreground objects of a ConceptGraphs *_post.pkl.gz (to_serializable dicts)."""
    if not isinstance(data, dict) or "objects" not in data:
        raise ExportError("not a ConceptGraphs map: expected a dict with 'objects' (a *_post.pkl.gz from pcd_saves/)")
    if not isinstance(data["objects"], list):
        raise ExportError("not a ConceptGraphs map: 'objects' is not a list")
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
        raise ExportError("not a BBQ map: expected {'objects': [...]}")
    for i, o in enumerate(objects):
        if not isinstance(o, dict):
            raise ExportError(f"object {i} is {type(o).__name__}, not a dict")
        if "pcd_np" not in o:
            raise ExportError(f"object {i} has no 'pcd_np'")
        if "clip_ft" not in o:
            raise ExportError(f"object {i} has no 'clip_ft': export the map with features (the OSMa adaptor's *_with_feats.pkl.gz)")
    return objects


def cmd_init(args):
    path = os.path.join(args.out, "submission.json")
    method = {"name": args.method, "description": args.description}
    if args.paper_url:
        method["paper_url"] = args.paper_url
    if args.code_url:
        method["code_url"] = args.code_url
    with reading(path):
        os.makedirs(args.out, exist_ok=True)
        with open(path, "w") as f:
            json.dump({"format": "osmab-submission/1", "release": args.release, "method": method}, f, indent=2)
    print(f"{args.out}/submission.json written")


def cmd_text_features(args):
    with reading(args.classes):
        with open(args.classes) as f:
            classes = json.load(f)["classes"]
        ids = np.array([c["id"] for c in classes], dtype=np.int64)
    with reading(args.embeddings):
        embeddings = _array(np.load(args.embeddings), "embeddings", ndim=2, float32=True)
        if len(embeddings) != len(ids):
            raise ExportError(f"{len(embeddings)} embeddings for {len(ids)} classes; embed every class name of classes.json in order")
    path = os.path.join(args.out, "text_features.npz")
    with reading(path):
        np.savez_compressed(path, class_ids=ids, features=embeddings)
    print(f"{args.out}/text_features.npz: {len(ids)} classes × {embeddings.shape[1]} dimensions")


def cmd_method(args, objects_of, graph_arg):
    with reading(args.map):
        objects = objects_of(load_pickle(args.map))
        points, count = write_map(args.out, args.lighting, args.scene, objects, "clip_ft")
    message = f"maps/{args.lighting}/{args.scene}.npz: {count} objects, {points} points"
    graph_path = getattr(args, graph_arg)
    if graph_path:
        with reading(graph_path):
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
    except Exception as e:  # a malformed input ends in one line on stderr, never a traceback
        if os.environ.get("OSMAB_EXPORT_DEBUG") and not isinstance(e, ExportError):
            raise
        print(f"osmab_export: {describe(e)}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
