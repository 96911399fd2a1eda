"""Size bounds for the arrays-only unpickler: what a small pickle may ask to build.

A pickle stream can ask for an array of any shape in a few bytes (``ndarray((2**40,))``), and a list that holds
itself twice, nested 40 deep, is 40 objects in the file but 2**40 when walked. Arrays are checked before they are
allocated (constructor arguments, and the state set on them), and the loaded object is copied into plain
containers while counting every element reached (shared references count each time), to a nesting depth, and the
bytes of every array reached at its full size: forty views of one buffer with zero strides cost nothing in the file
and nothing when loaded, but each becomes a full array when it is used.
"""

from __future__ import annotations

import math
import pickle
from typing import Any

import numpy as np

MAX_ARRAY_BYTES = 2**30  # one array; also the largest pickle stream read
MAX_TOTAL_BYTES = 3 * 2**29  # all arrays of one loaded object, each counted at its full size (views too)
MAX_ELEMENTS = 1_000_000  # containers and values reached when the loaded object is walked as a tree
MAX_DEPTH = 32  # nesting of containers


def check_array_size(shape: Any, dtype: Any) -> None:
    """UnpicklingError unless ``shape`` is a tuple of whole non-negative sizes and the array fits the bound."""
    shape = (shape,) if isinstance(shape, int) else shape
    if not isinstance(shape, tuple) or not all(isinstance(n, int) and n >= 0 for n in shape) or len(shape) > 32:
        raise pickle.UnpicklingError(f"array shape {shape!r} is not a tuple of sizes")
    itemsize = np.dtype(dtype).itemsize if dtype is not None else 8
    if math.prod(shape) * max(itemsize, 1) > MAX_ARRAY_BYTES:
        raise pickle.UnpicklingError(f"an array of shape {shape} and {itemsize}-byte items is over the size bound")


class BoundedArray(np.ndarray):
    """``numpy.ndarray`` as the unpickler builds it: shapes checked before any memory is taken."""

    def __new__(cls, shape: Any, dtype: Any = float, *args: Any, **kwargs: Any) -> BoundedArray:
        check_array_size(shape, dtype)
        return super().__new__(cls, shape, dtype, *args, **kwargs)

    def __setstate__(self, state: Any) -> None:
        fields = state[1:] if isinstance(state, tuple) and len(state) == 5 else state
        if not isinstance(fields, tuple) or len(fields) != 4:
            raise pickle.UnpicklingError("malformed array state")
        check_array_size(fields[0], fields[1])
        super().__setstate__(state)


def bounded_reconstruct(reconstruct: Any) -> Any:
    """numpy's ``_reconstruct`` for ``BoundedArray`` only, its shape checked first."""

    def build(subtype: Any, shape: Any, dtype: Any) -> Any:
        if subtype is not BoundedArray:
            raise pickle.UnpicklingError("only numpy arrays may be reconstructed")
        check_array_size(shape, np.uint8 if isinstance(dtype, bytes) else dtype)
        return reconstruct(subtype, shape, dtype)

    return build


def plain_copy(obj: Any) -> Any:
    """``obj`` with its arrays as plain ndarrays and its containers copied, each element counted; UnpicklingError
    past ``MAX_ELEMENTS`` elements, ``MAX_DEPTH`` levels or ``MAX_TOTAL_BYTES`` of arrays at their full sizes."""
    count, size = [0], [0]

    def copy(value: Any, depth: int) -> Any:
        count[0] += 1
        if count[0] > MAX_ELEMENTS:
            raise pickle.UnpicklingError(f"the data expands to more than {MAX_ELEMENTS} elements")
        if depth > MAX_DEPTH:
            raise pickle.UnpicklingError(f"containers nested more than {MAX_DEPTH} deep")
        if isinstance(value, dict):
            return {copy(k, depth + 1): copy(v, depth + 1) for k, v in value.items()}
        if isinstance(value, (list, tuple)):
            return type(value)(copy(v, depth + 1) for v in value)
        if isinstance(value, np.ndarray):
            size[0] += value.size * value.dtype.itemsize  # as materialised, whatever the strides
            if size[0] > MAX_TOTAL_BYTES:
                raise pickle.UnpicklingError(
                    f"its arrays come to more than {MAX_TOTAL_BYTES / 2**30:.1f} GiB when materialised"
                )
            array = value.view(np.ndarray)
            if array.dtype.hasobject:
                flat = [copy(v, depth + 1) for v in array.ravel()]
                array = np.empty(array.shape, dtype=object)
                array.ravel()[:] = flat if flat else array.ravel()
            return array
        return value

    return copy(obj, 0)
