"""The limits of the knees and elbows, and the motion moved inside them with the least change in the images.

A knee or an elbow is a hinge carried by a ball joint (hip, shoulder): the lower bone turns about one axis
perpendicular to the upper bone, by its *flexion*, and where that axis points about the upper bone is the ball
joint's *twist*, measured from the axis the limb carries when it swings from hanging by the shortest way
(:func:`lifting.anatomy.hinges.carried_axis`). Three joints show a bent limb's axis only up to its sign: the
same points are a flexion with one twist and the opposite flexion with the twist half a turn away. Of the two,
:func:`hinge_coordinates` reads the one whose twist is within a quarter turn of the carried axis, which makes its
flexion :func:`lifting.anatomy.hinges.signed_flexion`.

A body holds (``FLEXION_RANGE_DEG``, ``TWIST_LIMITS_DEG``), as the bundled real motion capture does (80,210
frames of every clip in ``data/motion``, 1-3 % of each hinge's frames outside them):
flexion from 10 degrees hyperextended (1 % of its knees reach past that) to fully folded; where a limb is bent past
``BENT_DEG`` (straighter, its axis is noise), a hip turning its knee at most 60 degrees from the carried axis
(99.5 % of its knees bent past 20 degrees are within 54) and a shoulder its elbow at most 85 (the reading's edge).

:func:`within_limits` moves each limb that breaks them back inside by turning its middle joint (knee, elbow)
about the line from the limb's root to its end (the *swivel*): the hip or shoulder and the ankle or wrist stay
where they are and so do both bones' lengths: only the middle joint moves, by the smallest turn that reaches an
allowed pose. Where no swivel does (a limb swung about the vertical carries its axis along: a knee folded backwards
under its hip stays backwards however it swivels), the lower bone is turned about the upper one to the nearest
allowed axis (a backward bend becomes the same bend forwards), and a limb folded past ``FLEXION_RANGE_DEG``'s end
is opened in its plane to that end. A head turned from the trunk's line past ``HEAD_LIMIT_DEG`` (a neck folded
further than real motion capture ever shows) is turned back to it.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from platypose.lifting.anatomy.hinges import HINGE_JOINTS, carried_axis, hinge_bones, hinge_rests, overhead
from platypose.lifting.rotations import unit
from platypose.lifting.skeleton import JOINT_INDEX as J

FLEXION_RANGE_DEG = (-10.0, 150.0)
TWIST_LIMITS_DEG = (60.0, 60.0, 85.0, 85.0)  # HINGE_NAMES order: knees (the hips' rotation), elbows (the shoulders')
HEAD_LIMIT_DEG = 100.0  # the head's line (neck to head) from the trunk's (spine to thorax): 99.8 % of real frames
BENT_DEG = 10.0  # a limb bent less than this shows no axis worth limiting: its twist is free
INSIDE_DEG = 1.0  # a limb moved back inside its limits goes this far inside, not onto their edge
ON_EDGE_DEG = 0.01  # a limb this near a limit counts as past it (float32 files would round it either way)
SWIVEL_STEPS = 24  # turns of the middle joint tried about the root-to-end line, a full turn (15 degrees apart)
SWIVEL_BISECTIONS = 8  # halvings between the last turn outside the limits and the first inside (15 deg / 256)


def _bend_and_turn(
    upper: np.ndarray, lower: np.ndarray, neutral: np.ndarray, down: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """The angle between the bones (0 to 180) and the turn (-180 to 180) about the upper bone from the carried axis
    to the axis that bends the lower bone by that angle, degrees ``(...)`` (arguments as :func:`limb_reading`); the
    turn is 0 where the upper bone points overhead (:func:`lifting.anatomy.hinges.overhead`: no carried axis)."""
    neutral, down, upper = (torch.as_tensor(np.asarray(v, np.float64)) for v in (neutral, down, upper))
    carried, up = carried_axis(neutral, down, upper).numpy(), overhead(down, upper).numpy()
    upper = upper.numpy()
    normal = np.cross(upper, lower)
    angle = np.degrees(np.arctan2(np.linalg.norm(normal, axis=-1), np.sum(upper * lower, axis=-1)))
    axis = unit(normal)
    turn = np.degrees(np.arctan2(np.sum(np.cross(carried, axis) * upper, axis=-1), np.sum(carried * axis, axis=-1)))
    return angle, np.where(up, 0.0, turn)


def limb_reading(
    upper: np.ndarray, lower: np.ndarray, neutral: np.ndarray, down: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Flexion and twist in degrees ``(...)`` of limbs with unit ``upper`` and ``lower`` bones ``(..., 3)``, carried by
    a body whose ``neutral`` hinge axis and hanging direction ``down`` are ``(..., 3)`` (see the module)."""
    return _signed(*_bend_and_turn(upper, lower, neutral, down))


def _signed(angle: np.ndarray, turn: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Flexion and twist of a bend by ``angle`` about the axis ``turn`` from the carried one (:func:`_bend_and_turn`):
    the reading whose twist lies within a quarter turn (see the module)."""
    back = np.abs(turn) > 90.0
    return np.where(back, -angle, angle), np.where(back, turn - np.copysign(180.0, turn), turn)


def hinge_coordinates(joints: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Flexion and twist in degrees ``(..., 4)``, :data:`lifting.anatomy.hinges.HINGE_NAMES` order, of joints
    ``(..., 17, 3)``."""
    values = torch.as_tensor(np.asarray(joints, np.float64))
    upper, lower = (v.numpy() for v in hinge_bones(values))
    neutral, down = (v.numpy() for v in hinge_rests(values))
    return limb_reading(upper, lower, neutral, down)


def limit_excess(flexion: np.ndarray, twist: np.ndarray) -> np.ndarray:
    """Degrees ``(..., 4)`` by which hinges of ``flexion`` and ``twist`` ``(..., 4)`` are past their limits (0 inside)."""
    return _past(flexion, twist, np.asarray(TWIST_LIMITS_DEG))


def _past(flexion, twist, twist_limit, inside: float = 0.0, folding: bool = True) -> np.ndarray:
    """Degrees past the limits (``twist_limit`` broadcast against ``twist``), narrowed by ``inside`` degrees; with
    ``folding`` False a fold past the range's end does not count."""
    low, high = FLEXION_RANGE_DEG
    over = np.maximum(low + inside - flexion, 0.0) + (np.maximum(flexion - high, 0.0) if folding else 0.0)
    turned = np.maximum(np.abs(twist) - (twist_limit - inside), 0.0)
    return over + np.where(np.abs(flexion) > BENT_DEG, turned, 0.0)


def _swivelled(root: np.ndarray, middle: np.ndarray, end: np.ndarray, turn: np.ndarray) -> np.ndarray:
    """Middle joints ``(..., 3)`` turned by ``turn`` radians ``(...)`` about the line from ``root`` to ``end``."""
    axis = unit(end - root)
    arm = middle - root
    cos, sin = np.cos(turn)[..., None], np.sin(turn)[..., None]
    along = np.sum(axis * arm, axis=-1, keepdims=True) * axis
    return root + along + cos * (arm - along) + sin * np.cross(axis, arm)


def _swivel_excess(
    root: np.ndarray, middle: np.ndarray, end: np.ndarray, neutral: np.ndarray, down: np.ndarray, hinge: int, turn
) -> np.ndarray:
    """Degrees past hinge ``hinge``'s limits, narrowed by ``INSIDE_DEG``, of limbs ``(M, 3)`` each with its middle joint
    swivelled by ``turn`` (folding too far is not a swivel's to mend)."""
    moved = _swivelled(root, middle, end, turn)
    neutral, down = np.broadcast_to(neutral, moved.shape).copy(), np.broadcast_to(down, moved.shape).copy()
    flexion, twist = limb_reading(unit(moved - root), unit(end - moved), neutral, down)
    return _past(flexion, twist, TWIST_LIMITS_DEG[hinge], INSIDE_DEG, folding=False)


def _smallest_swivel(
    root: np.ndarray, middle: np.ndarray, end: np.ndarray, neutral: np.ndarray, down: np.ndarray, hinge: int
) -> np.ndarray:
    """Turns ``(M,)`` radians of the smallest swivel putting limbs ``(M, 3)`` of hinge ``hinge`` inside its limits
    (the one leaving the least excess where none does)."""
    grid = np.linspace(-math.pi, math.pi, SWIVEL_STEPS + 1)
    grid = grid[np.argsort(np.abs(grid), kind="stable")]  # 0 first, then ever larger turns either way
    turns = np.broadcast_to(grid[:, None], (len(grid), len(root)))
    excess = _swivel_excess(root, middle, end, neutral, down, hinge, turns)  # (grid, M): every turn at once
    inside = excess <= 0.0
    best = np.where(inside.any(axis=0), np.argmax(inside, axis=0), np.argmin(excess, axis=0))
    outer, inner = np.zeros(len(root)), grid[best]  # the boundary lies between no turn (outside) and the best
    for _ in range(SWIVEL_BISECTIONS):
        half = (outer + inner) / 2
        ok = _swivel_excess(root, middle, end, neutral, down, hinge, half) <= 0.0
        outer, inner = np.where(ok, outer, half), np.where(ok, half, inner)
    return np.where(inside.any(axis=0), inner, grid[best])


def within_limits(joints: np.ndarray) -> np.ndarray:
    """Joints ``(..., 17, 3)`` with every knee and elbow inside its limits (see the module); rows with NaN and limbs
    already inside are returned as they are."""
    out = np.array(joints, np.float64, copy=True)
    flat = out.reshape(-1, *out.shape[-2:])
    rows = np.flatnonzero(np.isfinite(flat).all(axis=(1, 2)))
    values = torch.as_tensor(flat[rows])
    neutral, down = (v.numpy() for v in hinge_rests(values))
    # read once: mending one limb leaves the others' readings as they are
    flexion, twist = limb_reading(*(v.numpy() for v in hinge_bones(values)), neutral, down)
    excess = _past(flexion, twist, np.asarray(TWIST_LIMITS_DEG), ON_EDGE_DEG)
    for hinge, (top, mid, low) in enumerate(HINGE_JOINTS):
        broken = excess[:, hinge] > 0.0
        if not broken.any():
            continue
        some, axis, hanging = rows[broken], neutral[broken, hinge], down[broken, hinge]
        root, middle, end = flat[some, top], flat[some, mid], flat[some, low]
        flat[some, mid] = _swivelled(root, middle, end, _smallest_swivel(root, middle, end, axis, hanging, hinge))
        flat[some, low] = _mended_end(flat[some, top], flat[some, mid], end, axis, hanging, hinge)
    flat[rows, J["head"]] = _head_within_limit(flat[rows])
    return out


def _head_within_limit(joints: np.ndarray) -> np.ndarray:
    """Heads ``(M, 3)`` of joints ``(M, 17, 3)`` whose line from the neck turns more than ``HEAD_LIMIT_DEG`` from the
    trunk's turned back to that limit in the plane of the two lines (the head is a leaf: nothing else moves)."""
    trunk = unit(joints[:, J["thorax"]] - joints[:, J["spine"]])
    line = joints[:, J["head"]] - joints[:, J["neck"]]
    length = np.linalg.norm(line, axis=-1, keepdims=True)
    angle = np.arccos(np.clip(np.sum(trunk * unit(line), axis=-1), -1.0, 1.0))
    side = unit(line - np.sum(line * trunk, axis=-1, keepdims=True) * trunk)
    limit = math.radians(HEAD_LIMIT_DEG)
    held = joints[:, J["neck"]] + length * (math.cos(limit) * trunk + math.sin(limit) * side)
    return np.where((angle > limit)[:, None], held, joints[:, J["head"]])


def _mended_end(
    root: np.ndarray, middle: np.ndarray, end: np.ndarray, neutral: np.ndarray, down: np.ndarray, hinge: int
) -> np.ndarray:
    """Ends ``(M, 3)`` of limbs of hinge ``hinge`` that no swivel brought inside their limits, turned about the upper
    bone to the nearest allowed axis (a bent limb: the twist's limit, bending forwards; a nearly straight one
    bent backwards: half a turn, the same bend forwards), then, folded past the range's end, opened in its
    plane to that end; the others as they are."""
    upper, lower = unit(middle - root), end - middle
    angle, turn = _bend_and_turn(upper, unit(lower), neutral, down)
    limit = TWIST_LIMITS_DEG[hinge] - INSIDE_DEG
    wanted = np.where(angle > BENT_DEG, np.clip(turn, -limit, limit), np.where(np.abs(turn) > 90.0, turn + 180.0, turn))
    excess = _past(*_signed(angle, turn), TWIST_LIMITS_DEG[hinge])
    by = np.radians(np.where(excess > 0.0, wanted - turn, 0.0))[:, None]  # (only rows past a limit move)
    along = np.sum(lower * upper, axis=-1, keepdims=True) * upper
    across = lower - along
    lower = along + np.cos(by) * across + np.sin(by) * np.cross(upper, across)
    high = math.radians(FLEXION_RANGE_DEG[1])
    folded = np.linalg.norm(lower, axis=-1, keepdims=True) * (
        math.cos(high) * upper + math.sin(high) * unit(lower - along)
    )
    return middle + np.where((angle > FLEXION_RANGE_DEG[1])[:, None], folded, lower)
