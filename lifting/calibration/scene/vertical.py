"""The vertical vanishing point: where the scene's upright edges (door frames, cupboards, building corners) meet.

Candidates are the segments within ``MAX_TILT_DEG`` of the image's vertical (a camera rolled up to about 30
degrees, plus the verticals' convergence). Every pair of the ``PAIRS_FROM`` longest proposes the point where
they cross (an exhaustive, deterministic RANSAC); a point is scored by the length of candidates that point at it
within ``TOLERANCE_DEG`` (a truncated quadratic, so near misses count less). A point that makes the camera look
up more than ``MIN_PITCH_DEG`` (at the lens prior's focal length) or roll past ``MAX_ROLL_DEG`` is not the
world's vertical: the floor's edges running away from a camera that looks down meet above the image, and those
are left to the horizon (they may still win here: :func:`platypose.lifting.calibration.scene.manhattan.upright`
picks the world's up among the three directions found). The best point is refined by weighted least squares
over its inliers. The best supported point need not be the world's vertical, so the few best distinct ones are
candidates (:func:`find_verticals`), each tried with the horizon's search; the scene they explain best decides.
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
CANDIDATES = 6  # distinct vertical points tried
SEPARATION_DEG = 0.7  # two candidates closer than this (the world's up they give) are one


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


def find_verticals(lines: Lines, focal: float, min_length_px: float, count: int = CANDIDATES) -> list[Vertical]:
    """Up to ``count`` distinct candidates for the vertical vanishing point of ``lines``, best supported first
    (``focal``: the lens prior's, normalised, to bound the camera's pitch and to tell points apart: two are one
    where the world's up they give differs by under ``SEPARATION_DEG``). Each has ``MIN_SEGMENTS`` segments of at
    least ``min_length_px`` or more; none: an empty list. The best supported need not be the world's vertical: a
    long floor edge running away from the camera, near upright in the image, pulls it a little off."""
    upright = np.abs(lines.direction[:, 1]) >= np.cos(np.radians(MAX_TILT_DEG))
    candidates = np.nonzero(upright & (lines.length >= min_length_px))[0]
    if len(candidates) < 2:
        return []
    pool = lines.take(candidates)
    longest = np.argsort(-pool.length)[:PAIRS_FROM]
    i, j = np.triu_indices(len(longest), 1)
    points = np.cross(pool.normal[longest[i]], pool.normal[longest[j]])
    norm = np.linalg.norm(points, axis=1)
    points = points[norm > 1e-12] / norm[norm > 1e-12, None]
    points = points[plausible(points, focal)]
    scores = np.concatenate([score(pool, chunk, TOLERANCE_DEG) for chunk in _chunks(points)] or [np.zeros(0)])
    ups = _ups(points, focal)
    open_ = np.ones(len(points), bool)
    found: list[Vertical] = []
    near = np.cos(np.radians(SEPARATION_DEG))
    for seed in np.argsort(-scores):
        if len(found) == count:
            break
        if not open_[seed]:
            continue
        open_ &= np.abs(ups @ ups[seed]) < near
        refined = _refine(pool, points[seed])
        if refined is None:
            continue
        if any(same_point(refined, v.point, focal) for v in found):
            continue
        inliers = np.zeros(len(lines), bool)
        inliers[candidates[_inliers(pool, refined)]] = True
        found.append(Vertical(refined, inliers, float(lines.length[inliers].sum())))
    return found


def same_point(first: np.ndarray, second: np.ndarray, focal: float) -> bool:
    """Whether two vertical vanishing points (3,) give the world's up within ``SEPARATION_DEG`` at ``focal``."""
    ups = _ups(np.stack([first, second]), focal)
    return bool(abs(ups[0] @ ups[1]) >= np.cos(np.radians(SEPARATION_DEG)))


def _inliers(lines: Lines, point: np.ndarray) -> np.ndarray:
    """Which ``lines`` (N,) point at ``point`` within ``TOLERANCE_DEG``."""
    return misalignment(lines, point) < np.sin(np.radians(TOLERANCE_DEG))


def _refine(pool: Lines, best: np.ndarray) -> np.ndarray | None:
    """``best`` refined by weighted least squares over its inliers among ``pool``, or None where fewer than
    ``MIN_SEGMENTS`` agree."""
    tol = np.sin(np.radians(TOLERANCE_DEG))
    for _ in range(REFINE_ROUNDS):
        err = misalignment(pool, best)
        inliers = err < tol
        if inliers.sum() < MIN_SEGMENTS:
            return None
        weights = pool.length * (1.0 - (err / tol) ** 2).clip(0.0)
        refined = weighted_point(pool.take(inliers), weights[inliers])
        best = refined if refined @ best >= 0 else -refined
    return best if _inliers(pool, best).sum() >= MIN_SEGMENTS else None


def _ups(points: np.ndarray, focal: float) -> np.ndarray:
    """The unit camera-frame directions (M, 3) whose vanishing points are ``points`` (M, 3) (sign free)."""
    d = np.column_stack([points[:, :2] / focal, points[:, 2]])
    return d / np.maximum(np.linalg.norm(d, axis=1, keepdims=True), 1e-12)


def _chunks(points: np.ndarray, size: int = 256) -> list[np.ndarray]:
    return [points[k : k + size] for k in range(0, len(points), size)]
