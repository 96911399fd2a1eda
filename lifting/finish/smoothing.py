"""Paths smoothed over time: the least squared acceleration against the least change (a banded solve), over the
runs of frames where a person is present."""

from __future__ import annotations

import numpy as np
from scipy.linalg import solveh_banded


def smooth_over_time(values: np.ndarray, smoothness: float) -> np.ndarray:
    """Paths ``(T, ...)`` smoothed along T: the minimiser of ``|v' - v|^2 + smoothness * |D2 v'|^2``.

    ``D2`` is the second difference; the system is pentadiagonal and solved banded (memory linear in T).
    Fewer than 3 frames come back as they are.
    """
    T = len(values)
    if T < 3 or smoothness <= 0:
        return values
    diagonal, first, second = np.zeros(T), np.zeros(T - 1), np.ones(T - 2)  # of D2^T D2, rows (1, -2, 1)
    diagonal[:-2] += 1.0
    diagonal[1:-1] += 4.0
    diagonal[2:] += 1.0
    first[:-1] -= 2.0
    first[1:] -= 2.0
    banded = np.zeros((3, T))  # upper form of I + s D2^T D2 (scipy.linalg.solveh_banded)
    banded[2] = 1.0 + smoothness * diagonal
    banded[1, 1:] = smoothness * first
    banded[0, 2:] = smoothness * second
    flat = values.reshape(T, -1)
    return solveh_banded(banded, flat).reshape(values.shape)


def smooth_frames(values: np.ndarray, smoothness: float) -> np.ndarray:
    """:func:`smooth_over_time` along axis 1 of ``values`` ``(K, T, ...)``."""
    return np.moveaxis(smooth_over_time(np.moveaxis(values, 1, 0), smoothness), 0, 1)


def present_spans(present: np.ndarray) -> list[slice]:
    """The runs of True in ``present`` ``(T,)``, as slices."""
    edges = np.diff(np.concatenate([[0], present.astype(np.int8), [0]]))
    return [slice(int(a), int(b)) for a, b in zip(np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0])]
