"""One view's depth branches of the limbs, chosen once for a whole motion (a Viterbi pass over its frames).

Seen by one camera, a knee or an elbow at its bone's length from the hip or shoulder lies on its ray where the
ray meets that sphere: at two points, one nearer the camera than the other, and so does the ankle or the wrist
around it. Each frame of a limb has four such *branches* (the middle joint's two, times the end's two around
each), equal in the image. Placed frame by frame (:mod:`lifting.finish.rigid`) a limb takes whichever is nearer
the sampler's joints, and where the two are nearly as near, that flips between frames: knees and elbows bending
one way, then the other.

Per limb and hypothesis the branches of all frames are chosen together, minimising the sum over frames of

- ``LIMIT_WEIGHT`` times the squared degrees the branch is past the hinge's limits
  (:func:`lifting.anatomy.limits.limit_excess`, in radians): a body cannot take it;
- ``SAMPLED_WEIGHT`` times the squared distance of its two joints from the sampler's (metres): the prior's depth;
- ``STEP_WEIGHT`` times the squared distance its two joints move from the previous frame's branch: a limb stays
  on its branch unless the way over is short, which it is where the limb passes the ray's tangent.

The middle joint's branches are the two points of its ray at its bone's length from the root; the end's, those
of its ray around the chosen middle joint, or, where that ray passes by, its nearest point at the bone's length.
"""

from __future__ import annotations

import numpy as np
import torch

from platypose.lifting.anatomy.hinges import HINGE_JOINTS, hinge_rests
from platypose.lifting.anatomy.limits import limb_reading, limit_excess
from platypose.lifting.rotations import unit

LIMIT_WEIGHT = 10.0  # per squared radian past a limit: 20 degrees past costs as much as a 0.35 m jump
SAMPLED_WEIGHT = 1.0  # per square metre from the sampler's joints
STEP_WEIGHT = 1.0  # per square metre moved between frames


def ray_sphere_points(centre: np.ndarray, point: np.ndarray, middle: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """The two points ``(..., 2, 3)`` where the ray from camera ``centre`` ``(3,)`` through ``point`` ``(..., 3)`` meets
    the sphere of ``radius`` ``(...)`` about ``middle`` ``(..., 3)``, nearer first; where it misses, the sphere's point
    nearest the ray, twice."""
    ray = unit(point - centre)
    closest = np.sum(ray * (middle - centre), axis=-1)  # along the ray to the point nearest the sphere's centre
    gap = centre + closest[..., None] * ray - middle
    half = np.sqrt(np.maximum(radius**2 - np.sum(gap**2, axis=-1), 0.0))
    hits = centre + (closest[..., None] + np.stack([-half, half], axis=-1))[..., None] * ray[..., None, :]
    nearest = middle + radius[..., None] * unit(gap)
    missed = (np.sum(gap**2, axis=-1) > radius**2)[..., None, None]
    return np.where(missed, nearest[..., None, :], hits)


def limb_branches(
    limb: np.ndarray, centre: np.ndarray, upper: np.ndarray, lower: np.ndarray, seen: np.ndarray
) -> np.ndarray:
    """The four branches ``(..., 4, 2, 3)`` (middle, end) of limbs with joints ``(..., 3, 3)`` (root, middle, end) and
    bone lengths ``upper``, ``lower`` ``(...)`` seen from camera ``centre`` ``(3,)``: the middle joint's two, times the
    end's two. A joint not ``seen`` ``(..., 2)`` (middle, end) has no ray: an unseen middle joint stays where it is,
    an unseen end keeps its bone's direction from whichever middle joint."""
    root, middle, end = limb[..., 0, :], limb[..., 1, :], limb[..., 2, :]
    middles = ray_sphere_points(centre, middle, root, upper)  # (..., 2, 3)
    middles = np.where(seen[..., 0, None, None], middles, middle[..., None, :])
    ends = ray_sphere_points(centre, end[..., None, :], middles, lower[..., None])  # (..., 2, 2, 3)
    carried = middles[..., None, :] + (end - middle)[..., None, None, :]
    ends = np.where(seen[..., 1, None, None, None], ends, carried)
    middles = np.broadcast_to(middles[..., :, None, :], ends.shape)
    return np.stack([middles, ends], axis=-2).reshape(*end.shape[:-1], 4, 2, 3)


def viterbi(unary: np.ndarray, branches: np.ndarray) -> np.ndarray:
    """The branch ``(R, T)`` per row and frame minimising the unary costs ``(R, T, S)`` plus ``STEP_WEIGHT`` times the
    squared move of the branches' points ``(R, T, S, 2, 3)`` between consecutive frames (NaN costs nothing)."""
    R, T, S = unary.shape
    unary = np.nan_to_num(unary)
    step = branches[:, 1:, None] - branches[:, :-1, :, None]  # (R, T - 1, S_before, S_now, 2, 3)
    moves = STEP_WEIGHT * np.nan_to_num(np.sum(step**2, axis=(-1, -2)))  # (R, T - 1, S_before, S_now)
    total = unary[:, 0].copy()
    came_from = np.zeros((R, T, S), dtype=np.int64)
    for t in range(1, T):
        cost = total[:, :, None] + moves[:, t - 1]
        came_from[:, t] = np.argmin(cost, axis=1)
        total = np.min(cost, axis=1) + unary[:, t]
    chosen = np.zeros((R, T), dtype=np.int64)
    chosen[:, -1] = np.argmin(total, axis=1)
    for t in range(T - 1, 0, -1):
        chosen[:, t - 1] = came_from[np.arange(R), t, chosen[:, t]]
    return chosen


def choose_branches(
    placed: np.ndarray, sampled: np.ndarray, centre: np.ndarray, seen: np.ndarray, lengths: np.ndarray
) -> np.ndarray:
    """Motions ``(K, T, 17, 3)`` seen from one camera ``centre`` ``(3,)`` with each limb on the branches chosen over
    all frames (see the module); ``sampled`` ``(K, T, 17, 3)`` are the sampler's joints, ``seen`` ``(T, 17)`` which
    joints the camera sees (an unseen joint has no ray to choose a branch on: it keeps the one it was placed on),
    ``lengths`` ``(K, 16)`` the bone lengths (bone ``b`` has child ``b + 1``). Absent frames (NaN) stay absent."""
    out = np.array(placed, np.float64, copy=True)
    K, T = out.shape[:2]
    limbs = np.array(HINGE_JOINTS)  # (4, 3): root, middle, end per hinge
    joints = np.moveaxis(out[:, :, limbs], 2, 0)  # (4, K, T, 3, 3): every limb at once
    upper = np.broadcast_to(lengths.T[limbs[:, 1] - 1, :, None], (4, K, T))
    lower = np.broadcast_to(lengths.T[limbs[:, 2] - 1, :, None], (4, K, T))
    sight = np.broadcast_to(seen[:, limbs[:, 1:]].transpose(1, 0, 2)[:, None], (4, K, T, 2))
    branches = limb_branches(joints, centre, upper, lower, sight)  # (4, K, T, 4, 2, 3)
    neutral, down = (np.moveaxis(v.numpy(), 2, 0) for v in hinge_rests(torch.as_tensor(np.nan_to_num(out))))
    flexion, twist = limb_reading(
        unit(branches[..., 0, :] - joints[:, :, :, None, 0]),
        unit(branches[..., 1, :] - branches[..., 0, :]),
        np.broadcast_to(neutral[:, :, :, None], branches.shape[:-2] + (3,)).copy(),
        np.broadcast_to(down[:, :, :, None], branches.shape[:-2] + (3,)).copy(),
    )  # (4, K, T, 4 branches)
    excess = np.stack([limit_excess(flexion[h, ..., None], twist[h, ..., None])[..., h] for h in range(4)])
    wanted = np.moveaxis(sampled[:, :, limbs[:, 1:]], 2, 0)[:, :, :, None]  # (4, K, T, 1, 2, 3)
    unary = LIMIT_WEIGHT * np.radians(excess) ** 2 + SAMPLED_WEIGHT * np.sum((branches - wanted) ** 2, axis=(-1, -2))
    chosen = viterbi(unary.reshape(4 * K, T, 4), branches.reshape(4 * K, T, 4, 2, 3)).reshape(4, K, T)
    picked = np.take_along_axis(branches, chosen[..., None, None, None], axis=3)[:, :, :, 0]  # (4, K, T, 2, 3)
    present = np.isfinite(joints).all(axis=(-1, -2))  # (4, K, T)
    for hinge, (_, mid, low) in enumerate(HINGE_JOINTS):
        out[:, :, [mid, low]] = np.where(present[hinge, ..., None, None], picked[hinge], out[:, :, [mid, low]])
    return out
