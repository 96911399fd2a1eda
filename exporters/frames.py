"""Per-frame arrays too long to hold: an on-disk ``.npy`` read and written in chunks of frames.

``platypose lift`` streams each person's hypotheses into a :class:`FrameArray` in
its staging folder, and the exporters read every array (on disk or in memory)
through :func:`frame_chunks`, so memory stays bounded whatever the length. Each
read or write maps the file only for that access: pages read or written do not
stay in the process's resident memory.
"""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

CHUNK_FRAMES = 1024


def frame_chunks(total: int) -> Iterator[slice]:
    """Consecutive slices of at most ``CHUNK_FRAMES`` frames covering ``0 .. total``."""
    for start in range(0, total, CHUNK_FRAMES):
        yield slice(start, min(start + CHUNK_FRAMES, total))


class FrameArray:
    """A ``.npy`` file used like an array: ``a[key]`` reads (a copy), ``a[key] = value`` writes (numpy indexing)."""

    def __init__(self, path: Path | str) -> None:
        self.path = Path(path)
        with open(self.path, "rb") as stream:
            major, _ = np.lib.format.read_magic(stream)
            read_header = np.lib.format.read_array_header_1_0 if major == 1 else np.lib.format.read_array_header_2_0
            shape, fortran, dtype = read_header(stream)
            self.offset = stream.tell()
        if fortran:
            raise ValueError(f"{self.path}: Fortran-ordered arrays are not supported")
        self.shape, self.dtype = tuple(shape), np.dtype(dtype)

    @classmethod
    def create(cls, path: Path | str, shape: tuple[int, ...], dtype: np.dtype | type) -> FrameArray:
        """A new zero-filled ``.npy`` of ``shape`` and ``dtype`` at ``path`` (sparse on disk until written)."""
        mapped = np.lib.format.open_memmap(path, mode="w+", dtype=dtype, shape=shape)
        del mapped
        return cls(path)

    @property
    def ndim(self) -> int:
        """Number of axes."""
        return len(self.shape)

    def __len__(self) -> int:
        return self.shape[0]

    def _map(self, mode: str) -> np.memmap:
        return np.memmap(self.path, dtype=self.dtype, mode=mode, offset=self.offset, shape=self.shape)

    def __getitem__(self, key: Any) -> np.ndarray:
        mapped = self._map("r")
        try:
            return np.array(mapped[key])
        finally:
            del mapped

    def __setitem__(self, key: Any, value: np.ndarray) -> None:
        mapped = self._map("r+")
        try:
            mapped[key] = value  # no flush: unmapping leaves the pages to the page cache, reads see them
        finally:
            del mapped

    def __array__(self, dtype: np.dtype | None = None, copy: bool | None = None) -> np.ndarray:
        """The whole array read into memory (``np.asarray(a)``; exporters read chunks instead)."""
        return self[...] if dtype is None else self[...].astype(dtype)


class Lead:
    """``array[lead]`` without reading it: ``Lead(a, p)[key]`` reads ``a[(p, *key)]`` only."""

    def __init__(self, array: np.ndarray | FrameArray, *lead: int) -> None:
        self.array, self.lead = array, lead
        self.shape = tuple(array.shape[len(lead) :])

    def __len__(self) -> int:
        return self.shape[0]

    def __getitem__(self, key: Any) -> np.ndarray:
        return np.asarray(self.array[self.lead + (key if isinstance(key, tuple) else (key,))])
