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
_PARENTS = np.asarray(PARENTS)
_SINGLE = tuple(j for j in range(NUM_JOINTS) if len(_CHILDREN[j]) == 1)


def _depth(j: int) -> int:
    """Number of bones from the root to joint ``j``."""
    return 0 if PARENTS[j] < 0 else 1 + _depth(PARENTS[j])


# Joints below the root, grouped by depth: a group's parents are all set before it.
_LEVELS = tuple(
    np.array([j for j in range(1, NUM_JOINTS) if _depth(j) == d])
    for d in range(1, 1 + max(map(_depth, range(NUM_JOINTS))))
)


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


def limit_twists(
    global_rot: np.ndarray, offsets: np.ndarray, max_turn: float, before: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Global rotations (T, 17, 3, 3) whose single-child joints roll by at most ``max_turn`` degrees per frame,
    and the last frame's local rotations (17, 3, 3), which the next chunk continues from.

    ``global_rot`` are the picked rotations, ``offsets`` (17, 3) the rest offsets (a joint's bone runs along
    its child's offset), ``before`` (17, 3, 3) the local rotations of the frame before the first (a previous
    chunk's last), or None to take the first frame's as they are. Joints with several children or none keep
    their local rotation; leaves follow their parent.
    """
    T = len(global_rot)
    out = global_rot.copy()
    axes = np.zeros((NUM_JOINTS, 3))
    single = np.zeros(NUM_JOINTS, dtype=bool)
    for j in _SINGLE:
        axes[j], single[j] = _unit(offsets[_CHILDREN[j][0]]), True
    limit = np.radians(max_turn)
    previous = before
    for t in range(T):
        local = np.broadcast_to(np.eye(3), (NUM_JOINTS, 3, 3)).copy()
        local[0] = out[t, 0]
        for level in _LEVELS:
            parents = _PARENTS[level]
            picked = np.swapaxes(out[t, parents], -1, -2) @ global_rot[t, level]
            ones = single[level]
            if previous is not None and ones.any():
                js, a = level[ones], axes[level[ones]]
                swing, turn = swing_twist(np.swapaxes(previous[js], -1, -2) @ picked[ones], a)
                picked[ones] = previous[js] @ swing @ rotvec_matrices(a * np.clip(turn, -limit, limit)[:, None])
            leaves = np.array([not _CHILDREN[j] for j in level])
            picked[leaves] = np.eye(3)
            local[level] = picked
            out[t, level] = out[t, parents] @ picked
        previous = local
    return out, previous
