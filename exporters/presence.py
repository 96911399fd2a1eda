"""Whether a person's joints hold a body in a frame: the presence rule of every per-frame file and of the result."""

from __future__ import annotations

import numpy as np

MIN_BODY_EXTENT_M = 0.05  # a person whose 17 joints fit in a box this wide (any axis) is no body


def present_frames(joints: np.ndarray) -> np.ndarray:
    """Frames ``(..., T)`` of joints ``(..., T, 17, 3)`` metres that hold a body: every joint finite and the joints
    spread over at least ``MIN_BODY_EXTENT_M`` along some axis."""
    finite = np.isfinite(joints).all(axis=(-1, -2))
    with np.errstate(invalid="ignore"):
        extent = np.nan_to_num(np.ptp(joints, axis=-2).max(axis=-1), nan=0.0)
    return finite & (extent >= MIN_BODY_EXTENT_M)
