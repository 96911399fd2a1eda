"""What the arrays of an ``.npz`` file claim in their headers, checked before any of them is loaded.

An npz is a zip of ``.npy`` members, each a few bytes of header stating a shape and a type, then the values. A
damaged or crafted file can state a shape of hundreds of GiB in a 2 kB file, or deflate gigabytes of zeros into
megabytes; numpy allocates what the header states and reads that many bytes. So the sizes the headers state are the
memory a load takes: bounding them (per array and in all) bounds the load, whatever the compressed size.
"""

from __future__ import annotations

import math
import zipfile
from pathlib import Path

import numpy as np

MAX_ARRAY_BYTES = 2**30  # one array of an input file, as loaded
MAX_FILE_BYTES = 3 * 2**29  # all arrays of one input file (1.5 GiB)


def _header(stream) -> tuple[tuple[int, ...], np.dtype]:
    """The shape and type the ``.npy`` header at the start of ``stream`` claims."""
    version = np.lib.format.read_magic(stream)
    read = np.lib.format.read_array_header_1_0 if version == (1, 0) else np.lib.format.read_array_header_2_0
    shape, _, dtype = read(stream)
    return shape, dtype


def check_npy_size(path: Path, max_array: int = MAX_ARRAY_BYTES) -> None:
    """ValueError when the ``.npy`` file ``path`` claims more than ``max_array`` bytes in its header."""
    with open(path, "rb") as stream:
        shape, dtype = _header(stream)
    size = math.prod(shape) * dtype.itemsize
    if size > max_array:
        raise ValueError(
            f"its header claims {size / 2**30:.1f} GiB, over the {max_array / 2**30:.2g} GiB an array may hold"
        )


def claimed_sizes(path: Path) -> dict[str, int]:
    """Bytes each ``.npy`` member of the npz ``path`` claims in its header (name without ``.npy``); empty for a
    file that is not a zip (numpy's reader then says what is wrong); ValueError for a header numpy cannot read."""
    if not zipfile.is_zipfile(path):
        return {}
    return {name: math.prod(shape) * dtype.itemsize for name, (shape, dtype) in npz_headers(path).items()}


def check_npz_sizes(path: Path, max_array: int = MAX_ARRAY_BYTES, max_total: int = MAX_FILE_BYTES) -> None:
    """ValueError naming the first array whose header claims more than ``max_array`` bytes, or the total when all
    of them claim more than ``max_total``; nothing is loaded."""
    sizes = claimed_sizes(path)
    for name, size in sizes.items():
        if size > max_array:
            raise ValueError(
                f"array {name!r} claims {size / 2**30:.1f} GiB in its header, over the {max_array / 2**30:.2g} GiB "
                "an array may hold"
            )
    total = sum(sizes.values())
    if total > max_total:
        raise ValueError(
            f"its arrays claim {total / 2**30:.1f} GiB, over the {max_total / 2**30:.2g} GiB a file may hold"
        )


def npz_headers(path: Path) -> dict[str, tuple[tuple[int, ...], np.dtype]]:
    """The shape and type each ``.npy`` member of the npz ``path`` claims in its header (name without ``.npy``);
    nothing is loaded. ValueError for a file that is not a zip or a header numpy cannot read."""
    if not zipfile.is_zipfile(path):
        raise ValueError("not an npz file (no zip directory: truncated or not written by numpy)")
    headers = {}
    with zipfile.ZipFile(path) as archive:
        for info in archive.infolist():
            if info.filename.endswith(".npy"):
                with archive.open(info) as member:
                    headers[info.filename[:-4]] = _header(member)
    return headers
