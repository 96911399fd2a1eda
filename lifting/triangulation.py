"""Multi-view geometry on keypoints: confidence-weighted DLT triangulation and reprojection errors.

Pixels are undistorted with ``cv2.undistortPoints`` first, so the linear system is built in
normalised camera coordinates where every view has a comparable scale. A point seen (confidence
> 0) by fewer than ``min_views`` cameras, or whose rays meet only at infinity, comes back as NaN.
"""

from __future__ import annotations

import itertools
from collections.abc import Sequence

import numpy as np

from platypose.lifting.camera import Camera, project, undistort_normalized

# A person hypothesis must triangulate at least this fraction of the joints to be chosen.
MIN_JOINT_FRACTION = 0.5
BLOCK = 8192  # points triangulated at a time: the DLT's SVD needs about 1 KB per point


def triangulate(
    pixels: np.ndarray, confidences: np.ndarray, cameras: Sequence[Camera], min_views: int = 2
) -> np.ndarray:
    """World points ``(..., J, 3)`` from pixels ``(C, ..., J, 2)`` and confidences ``(C, ..., J)`` (weights of the DLT rows)."""
    pixels = np.asarray(pixels, dtype=np.float64)
    conf = np.asarray(confidences, dtype=np.float64)
    C = len(cameras)
    if pixels.shape[0] != C or conf.shape != pixels.shape[:-1] or pixels.shape[-1] != 2:
        raise ValueError(
            f"expected pixels (C={C}, ..., J, 2) and confidences (C, ..., J), got {pixels.shape}, {conf.shape}"
        )
    batch = pixels.shape[1:-1]
    flat, weights = pixels.reshape(C, -1, 2), conf.reshape(C, -1)
    blocks = range(0, max(flat.shape[1], 1), BLOCK)  # memory bounded for long tracks; one block when empty
    points = [_dlt(flat[:, b : b + BLOCK], weights[:, b : b + BLOCK], cameras, min_views) for b in blocks]
    return np.concatenate(points).reshape(*batch, 3)


def _dlt(flat: np.ndarray, weight: np.ndarray, cameras: Sequence[Camera], min_views: int) -> np.ndarray:
    """Points ``(N, 3)`` from pixels ``(C, N, 2)`` and weights ``(C, N)``: :func:`triangulate` on a flat block."""
    usable = (weight > 0) & np.all(np.isfinite(flat), axis=-1)
    weight = np.where(usable, weight, 0.0)
    flat = np.where(usable[..., None], flat, 0.0)
    norm = np.stack([undistort_normalized(flat[c], cam.K, cam.dist) for c, cam in enumerate(cameras)])
    P = np.stack([np.hstack([cam.R, cam.t[:, None]]) for cam in cameras])  # (C, 3, 4)
    rows_x = norm[..., 0:1] * P[:, None, 2] - P[:, None, 0]  # (C, N, 4)
    rows_y = norm[..., 1:2] * P[:, None, 2] - P[:, None, 1]
    A = np.concatenate([rows_x * weight[..., None], rows_y * weight[..., None]], axis=0).transpose(1, 0, 2)
    homogeneous = np.linalg.svd(A)[2][:, -1, :]  # (N, 4)
    with np.errstate(divide="ignore", invalid="ignore"):
        points = homogeneous[:, :3] / homogeneous[:, 3:4]
    # a point at infinity (rays that never meet, homogeneous w = 0) is no point: NaN, never +-inf, which later
    # interpolation would multiply by zero weights
    points[(usable.sum(axis=0) < min_views) | ~np.isfinite(points).all(axis=-1)] = np.nan
    return points


def reprojection_errors(points: np.ndarray, pixels: np.ndarray, cameras: Sequence[Camera]) -> np.ndarray:
    """Pixel distance ``(C, ..., J)`` between world points ``(..., J, 3)`` projected and observed pixels ``(C, ..., J, 2)``."""
    projected = np.stack([project(points, cam) for cam in cameras])
    return np.linalg.norm(projected - np.asarray(pixels, dtype=np.float64), axis=-1)


def median_reprojection_error(points: np.ndarray, keypoints: np.ndarray, cameras: Sequence[Camera]) -> float:
    """Median error in pixels over views, frames and joints with confidence > 0 and a triangulated point.

    ``points`` (..., J, 3); ``keypoints`` (C, ..., J, 3) as (u, v, confidence).
    """
    errors = reprojection_errors(points, keypoints[..., :2], cameras)
    seen = (keypoints[..., 2] > 0) & np.isfinite(errors)
    return float(np.median(errors[seen])) if seen.any() else float("nan")


def view_median_errors(points: np.ndarray, keypoints: np.ndarray, cameras: Sequence[Camera]) -> np.ndarray:
    """Median error in pixels per view (C,), over frames and joints with confidence > 0 (NaN if none)."""
    return np.array([median_reprojection_error(points, keypoints[c : c + 1], [cam]) for c, cam in enumerate(cameras)])


def _combination_scores(keypoints: np.ndarray, cameras: Sequence[Camera]) -> np.ndarray:
    """Median reprojection error of each candidate combination, ``(K, C, J, 3) -> (K,)`` (inf if too few joints)."""
    stacked = keypoints.transpose(1, 0, 2, 3)  # (C, K, J, 3)
    points = triangulate(stacked[..., :2], stacked[..., 2], cameras)
    errors = reprojection_errors(points, stacked[..., :2], cameras)
    seen = (stacked[..., 2] > 0) & np.isfinite(errors)
    enough = np.isfinite(points[..., 0]).mean(axis=-1) >= MIN_JOINT_FRACTION
    masked = np.where(seen, errors, np.nan).transpose(1, 0, 2).reshape(len(keypoints), -1)
    scores = np.full(len(keypoints), np.inf)
    has = enough & seen.any(axis=(0, 2))
    scores[has] = np.nanmedian(masked[has], axis=-1)
    return scores


def associate_single_person(candidates: Sequence[np.ndarray], cameras: Sequence[Camera]) -> np.ndarray:
    """Per frame, the one person per view whose combination triangulates best.

    ``candidates[c]`` is (T, P_c, J, 3) (u, v, confidence) for camera c. Only people with at least
    half their joints detected compete, and every view that has one takes part, so a view cannot be
    dropped to lower the error. Returns (C, T, J, 3), zero confidence where a view has nobody.
    """
    T, J = candidates[0].shape[0], candidates[0].shape[2]
    chosen = np.zeros((len(cameras), T, J, 3))
    for f in range(T):
        options = []
        for cand in candidates:
            people = cand[f][(cand[f][..., 2] > 0).mean(axis=-1) >= MIN_JOINT_FRACTION]
            options.append(people if len(people) else np.zeros((1, J, 3)))
        combos = list(itertools.product(*(range(len(o)) for o in options)))
        stacked = np.stack([np.stack([options[c][p] for c, p in enumerate(combo)]) for combo in combos])
        best = combos[int(np.argmin(_combination_scores(stacked, cameras)))]
        chosen[:, f] = [options[c][p] for c, p in enumerate(best)]
    return chosen
