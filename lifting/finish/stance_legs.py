"""Standing feet held where the sampler planted them, on a rigid leg (the one-view step of :mod:`lifting.finish.rigid`).

Rebuilt from the pelvis with smoothed bones, a foot that stood still in the sampler's motion would slide. So each
ankle that stands there goes back to where the sampler planted it (:func:`stance_targets`), as near as the leg
reaches bent by at least ``MIN_BEND_DEG``, the knee onto the circle that thigh and shin allow (:func:`two_bone_limb`).
Where the hip has moved on further from the planted place, the ankle goes as near as that leg reaches: a leg pulled
straight out to the planted place would snap its knee open for the frame and shut again as the foot lifts.
"""

from __future__ import annotations

import numpy as np

HOLD_SPREAD = 0.1  # metres: a standing ankle run of the sampler's that stays this near its mean is held at it
LEGS = ((1, 2, 3), (4, 5, 6))  # (hip, knee, ankle) of the right and left leg: the order of stance.ANKLES
MIN_BEND_DEG = 10.0  # a standing knee is bent at least this much (a heel strike's is 5-10 degrees)


def two_bone_limb(
    root: np.ndarray, target: np.ndarray, pole: np.ndarray, upper: np.ndarray, lower: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Middle and end joints ``(M, 3)`` of limbs from ``root`` ``(M, 3)`` with bones ``upper`` and ``lower``
    ``(M,)``: the end at ``target`` (on the line to it, as near as the limb reaches), the middle on the circle
    both bones allow, on the side of ``pole`` (where the middle joint was)."""
    reach = target - root
    distance = np.linalg.norm(reach, axis=-1, keepdims=True)
    axis = reach / np.maximum(distance, 1e-12)
    distance = np.clip(distance, np.abs(upper - lower)[:, None] + 1e-6, (upper + lower)[:, None] - 1e-6)
    along = (upper[:, None] ** 2 - lower[:, None] ** 2 + distance**2) / (2 * distance)
    radius = np.sqrt(np.maximum(upper[:, None] ** 2 - along**2, 0.0))
    side = pole - root
    side -= np.sum(side * axis, axis=-1, keepdims=True) * axis
    side /= np.maximum(np.linalg.norm(side, axis=-1, keepdims=True), 1e-12)
    return root + along * axis + radius * side, root + distance * axis


def stance_targets(ankles: np.ndarray, stance: np.ndarray) -> np.ndarray:
    """Where ankles ``(K, T, 3)`` should be while they stand (``stance`` ``(K, T)``): each run of standing frames at
    its mean, where the run stays within ``HOLD_SPREAD`` of it (a foot planted); elsewhere where they are."""
    K, T = stance.shape
    starts = stance & ~np.concatenate([np.zeros((K, 1), bool), stance[:, :-1]], axis=1)
    run = np.cumsum(starts.ravel()).reshape(K, T) - 1  # runs numbered in row order (a run never crosses rows)
    ids = run[stance]
    counts = np.bincount(ids, minlength=int(starts.sum()))[:, None]
    means = np.zeros((len(counts), 3))
    np.add.at(means, ids, ankles[stance])
    means /= np.maximum(counts, 1)
    spread = np.zeros(len(counts))
    np.maximum.at(spread, ids, np.linalg.norm(ankles[stance] - means[ids], axis=-1))
    targets = ankles.copy()
    targets[stance] = np.where((spread[ids] <= HOLD_SPREAD)[:, None], means[ids], ankles[stance])
    return targets


def hold_stance_legs(placed: np.ndarray, sampled: np.ndarray, stance: np.ndarray, lengths: np.ndarray) -> np.ndarray:
    """Rigid motions ``placed`` ``(K, T, 17, 3)`` whose standing ankles (``stance`` ``(K, T, 2)``, in the sampler's
    motions ``sampled``) go to where the sampler had them planted (:func:`stance_targets`), as near as the leg
    (``lengths`` ``(K, 16)``) reaches from the placed hip; the knee goes onto its circle on the side where it was
    placed. Feet that stood in the sampler's motion stand still; the bones keep their lengths. A
    planted place out of reach (module) is come as near as the leg bent by ``MIN_BEND_DEG`` reaches."""
    out = placed.copy()
    for side, (hip, knee, ankle) in enumerate(LEGS):
        standing = stance[..., side] & np.isfinite(sampled[:, :, ankle]).all(axis=-1)
        k, t = np.nonzero(standing)
        if len(k):
            target = stance_targets(np.nan_to_num(sampled[:, :, ankle]), standing)[k, t]
            thigh, shin = lengths[k, knee - 1], lengths[k, ankle - 1]  # bone b has child b + 1
            reach = np.sqrt(thigh**2 + shin**2 + 2 * thigh * shin * np.cos(np.radians(MIN_BEND_DEG)))
            offset = target - placed[k, t, hip]
            distance = np.linalg.norm(offset, axis=-1, keepdims=True)
            target = placed[k, t, hip] + offset * np.minimum(1.0, reach[:, None] / np.maximum(distance, 1e-12))
            middle, end = two_bone_limb(placed[k, t, hip], target, placed[k, t, knee], thigh, shin)
            out[k, t, knee], out[k, t, ankle] = middle, end
    return out
