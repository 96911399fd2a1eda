"""Size of a 2D person and distance between two 2D poses, in units of that size (shared by tracking and repair)."""

from __future__ import annotations

import warnings

import numpy as np


def person_size(pose: np.ndarray, min_confidence: float = 0.0) -> np.ndarray:
    """Person size in pixels, ``(..., 17, 3) -> (...)``: square root of the keypoint box area, at least 0.3 times the
    box's longer side (so a pose seen edge-on is not tiny); NaN with fewer than 2 visible joints."""
    visible = pose[..., 2] > min_confidence
    xy = np.where(visible[..., None], pose[..., :2], np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        extent = np.nanmax(xy, axis=-2) - np.nanmin(xy, axis=-2)
    size = np.fmax(np.sqrt(np.maximum(extent[..., 0] * extent[..., 1], 0.0)), 0.3 * np.max(extent, axis=-1))
    return np.where(visible.sum(axis=-1) >= 2, np.maximum(size, 1.0), np.nan)


def pose_distance(a: np.ndarray, b: np.ndarray, min_confidence: float) -> float:
    """Median distance over joints visible in both poses (17, 3), in units of the larger person size; inf if < 3 shared.

    The larger size is used so that a partial (small) detection does not inflate the distance.
    """
    shared = (a[:, 2] > min_confidence) & (b[:, 2] > min_confidence)
    if shared.sum() < 3:
        return np.inf
    scale = np.fmax(person_size(a, min_confidence), person_size(b, min_confidence))
    distances = np.linalg.norm(a[shared, :2] - b[shared, :2], axis=-1)
    return float(np.median(distances) / scale)
