"""The vertical vanishing point: where the scene's upright edges (door frames, cupboards, building corners) meet.

Candidates are the segments within ``MAX_TILT_DEG`` of the image's vertical (a camera rolled up to about 30
degrees, plus the verticals' convergence). Every pair of the ``PAIRS_FROM`` longest proposes the point where
they cross (an exhaustive, deterministic RANSAC); a point is scored by the length of candidates that point at it
within ``TOLERANCE_DEG`` (a truncated quadratic, so near misses count less). A point that makes the camera look
up more than ``MIN_PITCH_DEG`` (at the lens prior's focal length) or roll past ``MAX_ROLL_DEG`` is not the
world's vertical: the floor's edges running away from a camera that looks down meet above the image, and those
are left to the horizon (they may still win here: :func:`platypose.lifting.calibration.scene.manhattan.upright`
picks the world's up among the three directions found). The best point is refined by weighted least squares
over its inliers.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from platypose.lifting.calibration.pose_above_floor import pitch_roll
from platypose.lifting.calibration.scene.lines import Lines, direction_of, misalignment, weighted_point

MAX_TILT_DEG = 45.0
PAIRS_FROM = 80
TOLERANCE_DEG = 1.5
MIN_PITCH_DEG, MAX_PITCH_DEG, MAX_ROLL_DEG = -25.0, 89.0, 40.0
ROLL_SCALE_DEG, UP_SCALE_DEG = 20.0, 10.0
MIN_SEGMENTS = 4  # inliers the vertical needs
REFINE_ROUNDS = 3


@dataclass(frozen=True)
class Vertical:
    """The vertical vanishing point (3,) (normalised coordinates, unit), its inliers (N,) among the given lines,
    and their total length in pixels."""

    point: np.ndarray
    inliers: np.ndarray
    support_px: float


def score(lines: Lines, points: np.ndarray, tolerance_deg: float) -> np.ndarray:
    """Each point's (M,) support among ``lines``: their length times ``1 - (err / tol)^2`` where positive."""
    err = misalignment(lines, points) / np.sin(np.radians(tolerance_deg))
    return (np.clip(1.0 - err**2, 0.0, None) * lines.length).sum(axis=-1)


def unlikeliness(pitch_deg: float, roll_deg: float) -> float:
    """How unlikely a camera pitched and rolled so is: roll in units of ``ROLL_SCALE_DEG``, looking up in units of
    ``UP_SCALE_DEG`` (squared, summed); infinite past the bounds."""
    if not (MIN_PITCH_DEG <= pitch_deg <= MAX_PITCH_DEG and abs(roll_deg) <= MAX_ROLL_DEG):
        return float("inf")
    return (roll_deg / ROLL_SCALE_DEG) ** 2 + (min(pitch_deg, 0.0) / UP_SCALE_DEG) ** 2


def plausible(points: np.ndarray, focal: float) -> np.ndarray:
    """Which vertical vanishing points (M, 3) give a camera pitched and rolled within the bounds (M,)."""
    keep = np.zeros(len(points), bool)
    for i, point in enumerate(points):
        if not np.all(np.isfinite(point)) or np.linalg.norm(point) < 1e-9:
            continue
        pitch, roll = pitch_roll(direction_of(point / np.linalg.norm(point), focal))
        keep[i] = MIN_PITCH_DEG <= pitch <= MAX_PITCH_DEG and abs(roll) <= MAX_ROLL_DEG
    return keep


def find_vertical(lines: Lines, focal: float, min_length_px: float) -> Vertical | None:
    """The vertical vanishing point of ``lines`` (``focal``: the lens prior's, normalised, only to bound the
    camera's pitch), or None when fewer than ``MIN_SEGMENTS`` segments of at least ``min_length_px`` agree."""
    upright = np.abs(lines.direction[:, 1]) >= np.cos(np.radians(MAX_TILT_DEG))
    candidates = np.nonzero(upright & (lines.length >= min_length_px))[0]
    if len(candidates) < 2:
        return None
    pool = lines.take(candidates)
    longest = np.argsort(-pool.length)[:PAIRS_FROM]
    i, j = np.triu_indices(len(longest), 1)
    points = np.cross(pool.normal[longest[i]], pool.normal[longest[j]])
    norm = np.linalg.norm(points, axis=1)
    points = points[norm > 1e-12] / norm[norm > 1e-12, None]
    points = points[plausible(points, focal)]
    if len(points) == 0:
        return None
    best = points[np.argmax(np.concatenate([score(pool, chunk, TOLERANCE_DEG) for chunk in _chunks(points)]))]
    for _ in range(REFINE_ROUNDS):
        err = misalignment(pool, best)
        inliers = err < np.sin(np.radians(TOLERANCE_DEG))
        if inliers.sum() < MIN_SEGMENTS:
            return None
        weights = pool.length * (1.0 - (err / np.sin(np.radians(TOLERANCE_DEG))) ** 2).clip(0.0)
        refined = weighted_point(pool.take(inliers), weights[inliers])
        best = refined if refined @ best >= 0 else -refined
    inliers = misalignment(pool, best) < np.sin(np.radians(TOLERANCE_DEG))
    if inliers.sum() < MIN_SEGMENTS:
        return None
    mask = np.zeros(len(lines), bool)
    mask[candidates[inliers]] = True
    return Vertical(best, mask, float(pool.length[inliers].sum()))


def _chunks(points: np.ndarray, size: int = 256) -> list[np.ndarray]:
    return [points[k : k + size] for k in range(0, len(points), size)]
