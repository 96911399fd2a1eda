"""Twist continuity: each single-child bone's roll carried from frame to frame, turned by at most a limit.

A bone with one child has a direction the positions fix and a roll about itself that
nothing fixes (its child stays put however it rolls). The inverse kinematics
(:mod:`exporters.ik`) picks a roll per frame from the limb's plane, the lateral axis or
the parent's; where those are ill defined (an arm bent sideways, a plane that flips) the
pick jumps. :func:`limit_twists` walks down the tree frame by frame: each such joint's
local rotation starts from the frame before's, is swung by the smallest rotation onto its
new bone direction (parallel transport: no roll of its own), then turned about the bone
towards the picked roll by at most ``max_turn`` degrees. Bone directions, and so every
joint position, are unchanged; the roll follows the pick within the limit, and catches
up with it where the pick holds still.
"""

from __future__ import annotations

import numpy as np

from platypose.lifting.rotations import rotation_between, rotvec_matrices
from platypose.lifting.skeleton import NUM_JOINTS, PARENTS

_CHILDREN = tuple(tuple(c for c in range(NUM_JOINTS) if PARENTS[c] == j) for j in range(NUM_JOINTS))
_SINGLE = tuple(j for j in range(NUM_JOINTS) if len(_CHILDREN[j]) == 1)


def _unit(v: np.ndarray) -> np.ndarray:
    """Unit vectors along the last axis."""
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def swing_twist(delta: np.ndarray, axes: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotations ``delta`` (..., 3, 3) split as ``swing @ twist`` about unit ``axes`` (..., 3): the swings
    (..., 3, 3), the smallest rotations taking each axis to ``delta @ axis``, and the twists' signed angles
    (...) in radians about the axes."""
    swing = rotation_between(axes, _unit(np.einsum("...ij,...j->...i", delta, axes)))
    twist = np.swapaxes(swing, -1, -2) @ delta
    spin = np.stack(
        [twist[..., 2, 1] - twist[..., 1, 2], twist[..., 0, 2] - twist[..., 2, 0], twist[..., 1, 0] - twist[..., 0, 1]],
        axis=-1,
    )
    sin = 0.5 * np.sum(axes * spin, axis=-1)
    cos = 0.5 * (np.trace(twist, axis1=-2, axis2=-1) - 1.0)
    return swing, np.arctan2(sin, cos)


def _chain(steps: np.ndarray) -> np.ndarray:
    """Running products (T, 3, 3) ``steps[t] @ ... @ steps[0]`` of matrices ``steps`` (T, 3, 3), in log2(T) batches."""
    out = steps.copy()
    k = 1
    while k < len(out):
        out[k:] = out[k:] @ out[:-k]  # the right side is computed from the old values first
        k *= 2
    return out


def _limited_local(picked: np.ndarray, axis: np.ndarray, limit: float, before: np.ndarray | None) -> np.ndarray:
    """One joint's local rotations (T, 3, 3) with the roll about unit ``axis`` turning by at most ``limit``
    radians per frame, from its picked ones (T, 3, 3) and the limited one of the frame before (3, 3) or None.

    The frame with no roll of its own is carried from frame to frame by the smallest rotation of the bone
    (a running product, :func:`_chain`); the roll about it follows the pick's, clamped, frame by frame.
    """
    direction = picked @ axis  # (T, 3), unchanged by any roll
    start = picked[:1] if before is None else rotation_between(before @ axis, direction[:1]) @ before[None]
    swings = rotation_between(direction[:-1], direction[1:])
    carried = _chain(np.concatenate([start, swings]))
    _, wanted = swing_twist(np.swapaxes(carried, -1, -2) @ picked, np.broadcast_to(axis, direction.shape))
    roll, rolls = 0.0, []
    for target in wanted.tolist():  # plain floats: one small step per frame
        roll += min(max((target - roll + np.pi) % (2 * np.pi) - np.pi, -limit), limit)
        rolls.append(roll)
    return carried @ rotvec_matrices(axis * np.array(rolls)[:, None])


def limit_twists(
    global_rot: np.ndarray, offsets: np.ndarray, max_turn: float, before: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Global rotations (T, 17, 3, 3) whose single-child joints roll by at most ``max_turn`` degrees per frame,
    and the last frame's local rotations (17, 3, 3), which the next chunk continues from.

    ``global_rot`` are the picked rotations, ``offsets`` (17, 3) the rest offsets (a joint's bone runs along
    its child's offset), ``before`` (17, 3, 3) the local rotations of the frame before the first (a previous
    chunk's last), or None to take the first frame's as they are. Joints with several children or none keep
    their local rotation; leaves follow their parent. Joint by joint down the tree, all frames at once.
    """
    out = global_rot.copy()
    local = np.broadcast_to(np.eye(3), global_rot.shape).copy()
    local[:, 0] = global_rot[:, 0]
    limit = np.radians(max_turn)
    for j in range(1, NUM_JOINTS):  # parents come before their children
        p = PARENTS[j]
        if j in _SINGLE:
            picked = np.swapaxes(out[:, p], -1, -2) @ global_rot[:, j]
            axis = _unit(offsets[_CHILDREN[j][0]])
            local[:, j] = _limited_local(picked, axis, limit, None if before is None else before[j])
        elif _CHILDREN[j]:
            local[:, j] = np.swapaxes(out[:, p], -1, -2) @ global_rot[:, j]
        out[:, j] = out[:, p] @ local[:, j]
    return out, local[-1]
