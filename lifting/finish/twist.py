"""The trunk's twist held within what a body turns: the pelvis and the thorax face within ``TWIST_DEG`` of each other.

From one view a side-on person's hip line (or shoulder line) lies nearly along the camera's ray, so which hip is
nearer is barely seen, and the sampler sometimes turns one of the two bodies (the pelvis with its hips, the thorax
with its shoulders) to face the other way for a few frames while the other keeps its facing: a trunk twisted by
90-180 degrees, which no spine does (axial rotation of the thoracolumbar spine is about 40 degrees each way;
a golf swing's hip-shoulder separation about 50). Seen as a motion it is a pelvis that spins at thousands of degrees
a second and back.

Per hypothesis, where the two bodies' headings (their forward axes about the vertical) differ by more than
``TWIST_DEG``, the body that has left its own heading of the frames around (interpolated over the frames within the
limit) is turned about the vertical back to the other body's heading plus the twist of those frames. Its children
(hips, or shoulders and neck) move with it and the limbs hanging from them follow when the motion is rebuilt; the
other body, and every bone's direction, stay. A hypothesis twisted in every frame is left as it is (nothing says
which body is right).
"""

from __future__ import annotations

import numpy as np

from platypose.lifting.finish.rigid_shape import BODY_JOINTS
from platypose.lifting.rotations import rotvec_matrices
from platypose.lifting.skeleton import JOINT_INDEX

TWIST_DEG = 60.0  # largest heading difference between pelvis and thorax kept as it is
LEVEL_DEG = 60.0  # a body whose left-right axis is steeper than this has no heading
PELVIS, THORAX = BODY_JOINTS.index(JOINT_INDEX["pelvis"]), BODY_JOINTS.index(JOINT_INDEX["thorax"])


def body_headings(turns: np.ndarray) -> np.ndarray:
    """Heading (radians about world Z) of each body, rotations ``(..., B, 3, 3)`` -> ``(..., B)``: the direction of its
    left-right axis (hip line, shoulder line) about the vertical, a quarter turn from its facing. That axis stays
    near horizontal when the trunk bends forward, where the forward axis would point at the floor; NaN where it is
    more than ``LEVEL_DEG`` from horizontal (a body lying on its side: no heading)."""
    across = turns[..., :, 0]
    level = np.linalg.norm(across[..., :2], axis=-1) >= np.cos(np.radians(LEVEL_DEG))
    return np.where(level, np.arctan2(across[..., 1], across[..., 0]), np.nan)


def wrapped(angle: np.ndarray) -> np.ndarray:
    """Angles wrapped into [-pi, pi)."""
    return (angle + np.pi) % (2 * np.pi) - np.pi


def about_vertical(angle: np.ndarray) -> np.ndarray:
    """Rotations ``(..., 3, 3)`` by ``angle`` ``(...)`` radians about world Z."""
    return rotvec_matrices(np.multiply.outer(angle, [0.0, 0.0, 1.0]))


def untwisted(turns: np.ndarray) -> np.ndarray:
    """Bodies' rotations ``(K, T, B, 3, 3)`` (body frame to world, z forward; consecutive present frames) with each
    frame whose trunk twists past ``TWIST_DEG`` mended (see the module); frames where either body has no heading
    (:func:`body_headings`) are neither mended nor used."""
    heading = body_headings(turns)  # (K, T, B)
    twist = wrapped(heading[..., THORAX] - heading[..., PELVIS])  # (K, T)
    known = np.isfinite(twist)
    within = known & (np.abs(twist) <= np.radians(TWIST_DEG))
    beyond = known & ~within
    out = turns.copy()
    frames = np.arange(turns.shape[1])
    for k in np.nonzero(beyond.any(axis=1) & within.any(axis=1))[0]:
        good, bad = frames[within[k]], frames[beyond[k]]
        kept_twist = np.interp(bad, good, twist[k, good])
        own = [np.interp(bad, good, np.unwrap(heading[k, good, body])) for body in (PELVIS, THORAX)]
        pelvis_off = np.abs(wrapped(heading[k, bad, PELVIS] - own[0])) >= np.abs(
            wrapped(heading[k, bad, THORAX] - own[1])
        )
        target = np.where(pelvis_off, heading[k, bad, THORAX] - kept_twist, heading[k, bad, PELVIS] + kept_twist)
        moved = np.where(pelvis_off, PELVIS, THORAX)
        change = wrapped(target - heading[k, bad, moved])
        out[k, bad, moved] = about_vertical(change) @ turns[k, bad, moved]
    return out
