"""Whether the camera moved during the take: a static camera sees the same straight lines in every frame.

Each checked frame's long segments are looked for among the segments of the frames' median image (the scene
the estimate uses): a segment is found where one there runs at most ``ANGLE_DEG`` apart, its middle within
``OFFSET`` (share of the image diagonal) of that one's line and along its extent. A static camera finds most of
its long lines' length (people passing hide a little); a panned, tilted, zoomed or hand-held one finds few, and
its median is a blur.
"""

from __future__ import annotations

import numpy as np

from platypose.lifting.calibration.scene.segments import lengths

ANGLE_DEG = 2.0
OFFSET = 0.004
LONG = 0.03  # a long segment: this share of the image diagonal or more
MIN_FOUND = 0.5  # a frame whose long lines are found less than this (share of their length) moved
MIN_MOVED_FRAMES = 2  # this many such frames make a moving camera (one may be a person walking close by)


def found_share(segments: np.ndarray, reference: np.ndarray, diagonal: float) -> float | None:
    """The share of the long ``segments``' (N, 4) length that lies on ``reference`` segments (M, 4); None where
    there are no long segments."""
    long = segments[lengths(segments) >= LONG * diagonal]
    if len(long) == 0:
        return None
    if len(reference) == 0:
        return 0.0
    middle = (long[:, :2] + long[:, 2:]) / 2.0
    a = _unit(long)
    b = _unit(reference)
    parallel = np.abs(a @ b.T) >= np.cos(np.radians(ANGLE_DEG))  # (N, M)
    offset = middle[:, None, :] - reference[None, :, :2]  # from each reference start
    across = np.abs(offset[..., 0] * b[None, :, 1] - offset[..., 1] * b[None, :, 0])
    along = offset[..., 0] * b[None, :, 0] + offset[..., 1] * b[None, :, 1]
    tolerance = OFFSET * diagonal
    inside = (along >= -tolerance) & (along <= lengths(reference)[None] + tolerance)
    found = (parallel & (across <= tolerance) & inside).any(axis=1)
    size = lengths(long)
    return float(size[found].sum() / size.sum())


def moved(frame_segments: list[np.ndarray], reference: np.ndarray, diagonal: float) -> tuple[bool, list[float]]:
    """Whether the camera moved: ``MIN_MOVED_FRAMES`` or more of the frames' segments (each (N, 4)) find under
    ``MIN_FOUND`` of their long lines among the median's ``reference``; and each frame's share."""
    shares = [found_share(s, reference, diagonal) for s in frame_segments]
    known = [s for s in shares if s is not None]
    return sum(s < MIN_FOUND for s in known) >= MIN_MOVED_FRAMES, known


def _unit(segments: np.ndarray) -> np.ndarray:
    d = segments[:, 2:] - segments[:, :2]
    return d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)
