"""Read a pickled object array (as ``np.savez`` writes dicts) without running any of the file's code.

An ``.npy`` member of dtype object holds a pickle stream. Loading it with
``allow_pickle=True`` lets the file call any Python function. Here the stream is
read by an unpickler whose only callables are numpy's own array and dtype
constructors (and, for protocol 2, ``codecs.encode``): plain containers (dict, list, tuple, str, numbers) and numeric
arrays come back; any other global the stream names is refused before it is
looked up, so nothing in the file runs.
"""

from __future__ import annotations

import codecs
import io
import pickle
import zipfile
from pathlib import Path
from typing import Any

import numpy as np

from platypose.lifting.errors import InputError
from platypose.lifting.motion_io.pickle_bounds import MAX_ARRAY_BYTES, BoundedArray, bounded_reconstruct, plain_copy

# The callables numpy's pickles of arrays, dtypes and scalars name, taken from numpy itself so that
# both the numpy 1 (numpy.core) and numpy 2 (numpy._core) module names resolve to them.
_RECONSTRUCT = np.zeros(1).__reduce__()[0]
_SCALAR = np.float64(0).__reduce__()[0]
_ALLOWED = {
    "_reconstruct": bounded_reconstruct(_RECONSTRUCT),
    "ndarray": BoundedArray,
    "dtype": np.dtype,
    "scalar": _SCALAR,
}
_NUMPY_MODULES = {"numpy", "numpy.core.multiarray", "numpy._core.multiarray"}
# Pickle protocol 2 (Python 2 era files) stores bytes as _codecs.encode(text, "latin1"): it builds bytes, nothing else.
_BYTES_FROM_TEXT = ("_codecs", "encode")


def _latin1(text: Any, encoding: str = "latin1") -> bytes:
    """``codecs.encode`` as protocol 2 uses it: text to bytes in Latin-1, no other codec."""
    if not isinstance(text, str) or encoding.replace("-", "").lower() != "latin1":
        raise pickle.UnpicklingError("only latin1 text may be encoded")
    return codecs.encode(text, "latin1")


class _ArraysOnlyUnpickler(pickle.Unpickler):
    """An unpickler that resolves numpy's array constructors and nothing else."""

    def find_class(self, module: str, name: str) -> Any:
        if module in _NUMPY_MODULES and name in _ALLOWED:
            return _ALLOWED[name]
        if (module, name) == _BYTES_FROM_TEXT:
            return _latin1
        raise pickle.UnpicklingError(f"refused to load {module}.{name}")

    def persistent_load(self, pid: Any) -> Any:
        raise pickle.UnpicklingError("refused a persistent id")


def load_object_member(path: Path, key: str) -> Any:
    """The Python object stored under ``key`` in the npz ``path``; only containers and numeric arrays load.

    Raises InputError naming the file when the member is missing, is not an object array, or its
    pickle names anything but numpy's array constructors.
    """
    try:
        with zipfile.ZipFile(path) as archive, archive.open(f"{key}.npy") as member:
            stream = io.BytesIO(member.read(MAX_ARRAY_BYTES + 1))
    except KeyError:
        raise InputError(f"{path}: no '{key}' array") from None
    except (zipfile.BadZipFile, OSError) as exc:
        raise InputError(f"{path}: not a readable npz file ({exc})") from None
    try:
        version = np.lib.format.read_magic(stream)
        read_header = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
        _, _, dtype = read_header(stream)
    except ValueError as exc:
        raise InputError(f"{path}: '{key}' is not a valid .npy array ({exc})") from None
    if len(stream.getbuffer()) > MAX_ARRAY_BYTES:
        raise InputError(f"{path}: '{key}' is over {MAX_ARRAY_BYTES // 2**20} MiB; not loaded")
    if not dtype.hasobject:
        raise InputError(f"{path}: '{key}' must be an object array (a pickled dict), got dtype {dtype}")
    try:
        array = plain_copy(_ArraysOnlyUnpickler(stream).load())
    except (pickle.UnpicklingError, EOFError, ValueError, TypeError, AttributeError, IndexError) as exc:
        raise InputError(
            f"{path}: '{key}' holds more than bounded numpy arrays and containers ({exc}); not loaded"
        ) from None
    except (MemoryError, RecursionError):
        raise InputError(f"{path}: '{key}' is too large or too deeply nested; not loaded") from None
    return array.item() if isinstance(array, np.ndarray) and array.shape == () else array
