"""Where each person is and when: triangulated root paths, gap filling, and the frames a person is present.

Arrays follow :func:`lifting.tracks.stream.lift_tracks`: keypoints ``(C, T, P, 17, 3)``
(x, y, confidence; confidence 0 = missing) on one clock ``(T,)``.
"""

from __future__ import annotations

from collections.abc import Sequence
from itertools import pairwise

import numpy as np

from platypose.lifting.camera import Camera
from platypose.lifting.skeleton import JOINT_NAMES
from platypose.lifting.triangulation import triangulate

PELVIS = JOINT_NAMES.index("pelvis")


def triangulated_root(keypoints: np.ndarray, cameras: Sequence[Camera]) -> np.ndarray:
    """Pelvis paths ``(P, T, 3)`` triangulated from keypoints ``(C, T, P, 17, 3)``; NaN where < 2 views see it."""
    pelvis = keypoints[:, :, :, PELVIS]  # (C, T, P, 3)
    points = triangulate(pelvis[..., None, :2], pelvis[..., None, 2], cameras)[..., 0, :]  # (T, P, 3)
    return np.moveaxis(points, 0, 1)


def fill_gaps(path: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Path ``(T, D)`` with NaN rows filled by linear interpolation in time (ends: nearest value); all-NaN stays NaN."""
    known = np.isfinite(path).all(axis=-1)
    if known.all() or not known.any():
        return path.copy()
    return np.stack([np.interp(times, times[known], path[known, d]) for d in range(path.shape[-1])], axis=-1)


MIN_SEEN_JOINTS = 4  # joints with confidence > 0 a view must have for a person to be seen in a frame


def seen_frames(keypoints: np.ndarray, min_joints: int = MIN_SEEN_JOINTS) -> np.ndarray:
    """Frames ``(P, T)`` where some view of keypoints ``(C, T, P, 17, 3)`` sees a person: ``min_joints`` joints
    with confidence > 0. A present frame that is not seen is filled by the prior."""
    return ((np.nan_to_num(keypoints[..., 2]) > 0).sum(axis=-1) >= min_joints).any(axis=0).T


def presence(
    keypoints: np.ndarray, times: np.ndarray, max_gap_s: float = 1.0, min_joints: int = MIN_SEEN_JOINTS
) -> np.ndarray:
    """Frames ``(P, T)`` where a person is present: seen (:func:`seen_frames`), or inside a gap of at most
    ``max_gap_s`` between two seen frames (lifted through: the prior fills it)."""
    seen = seen_frames(keypoints, min_joints)  # (P, T)
    present = seen.copy()
    for p in range(seen.shape[0]):
        frames = np.nonzero(seen[p])[0]
        for a, b in pairwise(frames):
            if b - a > 1 and times[b] - times[a] <= max_gap_s:
                present[p, a:b] = True
    return present
