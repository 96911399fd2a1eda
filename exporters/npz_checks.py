"""Checks on a result npz before and after its arrays are loaded: what its headers claim, what its values hold.

A damaged or crafted file can claim arrays far larger than memory in a header of a few bytes (or compress millions
of frames into megabytes), and hold coordinates no person has: infinite, or kilometres from the origin. Both are
refused with the field named, before ``info`` or ``export`` works on them; NaN stays (a person absent in a frame).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from platypose.lifting.files.npz_limits import check_npz_sizes

MAX_FIELD_BYTES = 2**30  # one array of a result, as loaded
MAX_RESULT_BYTES = 5 * 2**28  # all of them (1.25 GiB: 20 hypotheses of one person over 70 minutes at 60 fps)
CHUNK = 2**22  # values checked at a time (no copy of a whole field)
MAX_COORDINATE_M = 1000.0  # a pose farther than this from the world origin is not a lift of a person


def check_field_sizes(path: Path) -> None:
    """ValueError naming the first ``.npy`` member whose header claims more than ``MAX_FIELD_BYTES``, or when
    all of them claim more than ``MAX_RESULT_BYTES`` (:func:`platypose.lifting.files.npz_limits.check_npz_sizes`)."""
    check_npz_sizes(path, MAX_FIELD_BYTES, MAX_RESULT_BYTES)


def check_coordinates(name: str, values: np.ndarray) -> None:
    """ValueError when ``values`` (metres) hold infinities or finite values farther than ``MAX_COORDINATE_M``."""
    flat = values.reshape(-1)
    far = 0.0
    for start in range(0, len(flat), CHUNK):
        block = flat[start : start + CHUNK]
        if np.isinf(block).any():
            raise ValueError(f"field {name!r} holds infinite coordinates (a damaged result)")
        with np.errstate(invalid="ignore"):
            far = max(far, float(np.nanmax(np.abs(block), initial=0.0)))
    if far > MAX_COORDINATE_M:
        raise ValueError(f"field {name!r} holds coordinates {far:.3g} m from the origin (over {MAX_COORDINATE_M:g} m)")
