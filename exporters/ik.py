"""Inverse kinematics of our 17-joint tree on a rigid skeleton (pure array maths).

Axes are BVH's (x left, y up, z forward, any unit). The rest pose stands upright
facing +z with the arms out sideways; :func:`rest_offsets` fits its bone
lengths and the shape of the two rigid bodies (pelvis with hips and spine,
thorax with shoulders and neck) once over a clip.

Per frame (:func:`fit_rotations`), every joint's global rotation is set from
the joints that define it, going down the tree from where the fitted chain has
put each joint:

- pelvis and thorax: the rotation that best maps their three children's rest
  offsets onto the observed ones (least squares, Kabsch);
- spine and neck: aimed at their child, rolled with the lateral axis (hips and
  shoulders for the spine, the thorax for the neck);
- thighs and upper arms: aimed at their child, rolled about the limb's hinge
  axis, so knees and elbows bend about one axis. The axis is
  carried from frame to frame with the upper bone and turns about it towards
  the normal of the hip-knee-ankle or shoulder-elbow-wrist plane where the limb
  is bent (signed as flexion where it bends past 60 degrees, else as the
  carried axis, so a plane swinging around the upper bone is followed through
  any angle) and towards the parent's axis swung onto the bone where it is
  straight (its plane is noise), by at most :data:`_MAX_TURN` per frame: no
  roll can pop, whatever the plane does;
- shins and forearms: the smallest swing from the upper bone onto theirs (a
  bend about the hinge where the limb's plane holds it, and never ill defined);
- wrists, ankles and head (no child to define them) keep their parent's rotation.

Then :func:`refine_rotations` solves all bone directions of each frame at
once by damped Gauss-Newton on the squared distances of the forward-kinematics
joints to the observed ones (the roll about each bone is left as set), and
:func:`exporters.twist.limit_twists` keeps each roll continuous in time. The Euler angles of the local
rotations are :mod:`exporters.euler`'s. Forward
kinematics is the importers' (:func:`platypose.lifting.motion_io.kinematics.forward_kinematics`).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from scipy.spatial.transform import Rotation

from platypose.lifting.motion_io.kinematics import forward_kinematics
from platypose.lifting.rotations import kabsch, rotation_between, skew, two_vector_frame
from platypose.lifting.skeleton import BODIES, BONES, JOINT_NAMES, NUM_JOINTS, PARENTS

CHILDREN: tuple[tuple[int, ...], ...] = tuple(
    tuple(c for c in range(NUM_JOINTS) if PARENTS[c] == j) for j in range(NUM_JOINTS)
)
_J = JOINT_NAMES.index

_LEFT, _RIGHT, _UP, _DOWN, _FORWARD = (1, 0, 0), (-1, 0, 0), (0, 1, 0), (0, -1, 0), (0, 0, 1)
# Rest direction of each joint's offset from its parent (the limbs and midline; the pelvis and thorax
# children get the direction measured in the clip, see rest_offsets).
REST_DIRECTIONS = np.array(
    [(0, 0, 0), _RIGHT, _DOWN, _DOWN, _LEFT, _DOWN, _DOWN, _UP, _UP, _UP, _UP]
    + [_LEFT, _LEFT, _LEFT, _RIGHT, _RIGHT, _RIGHT],
    dtype=np.float64,
)

_SPINE, _NECK, _HEAD = _J("spine"), _J("neck"), _J("head")
# Limbs: upper joint -> (lower joint, end joint, rest hinge axis). Flexion bends the lower bone
# forward (elbows) or backward (knees) about the hinge axis, which is d_upper x d_lower.
LIMBS: dict[int, tuple[int, int, tuple[int, int, int]]] = {
    _J("right_hip"): (_J("right_knee"), _J("right_ankle"), (1, 0, 0)),
    _J("left_hip"): (_J("left_knee"), _J("left_ankle"), (1, 0, 0)),
    _J("left_shoulder"): (_J("left_elbow"), _J("left_wrist"), (0, -1, 0)),
    _J("right_shoulder"): (_J("right_elbow"), _J("right_wrist"), (0, 1, 0)),
}
_LOWER = {lower: (upper, end, axis) for upper, (lower, end, axis) in LIMBS.items()}
_LEGS = (_J("right_hip"), _J("left_hip"))
_LIMB_ORDER = tuple(LIMBS)

# A limb's plane is defined between these sines of its bend (15-37 degrees). Its normal takes the
# carried axis's sign where they are within 73 degrees of parallel or opposite (cosine 0.3), else the
# default's. A hinge axis turns about its bone by at most 15 degrees per frame (on the bundled one-view
# lifts 10 and 15 leave the fewest joint steps over 45 degrees, 20 and 30 up to 6 more; less lags the
# plane longer; docs/results.md).
_BEND_SIN = (0.25, 0.6)
_SIGN_FROM_CARRIED, _MAX_TURN = 0.3, np.radians(15.0)
# A limb bent past 60 degrees (cosine 0.5) is flexed whatever its axis did before: no knee or elbow
# hyperextends that far, so its normal takes the sign of flexion.
_FOLD_COS = 0.5
# Weights of the vectors fitted to a rigid body: left, right and midline child.
_BODY_WEIGHTS = np.array([1.0, 1.0, 0.5])


def _unit(v: np.ndarray) -> np.ndarray:
    """Unit vectors along the last axis."""
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _apply(rot: np.ndarray, v: np.ndarray) -> np.ndarray:
    """``rot @ v`` for rotations (..., 3, 3) and vectors (..., 3) or (3,)."""
    return np.einsum("...ij,...j->...i", rot, v)


def body_directions(positions: np.ndarray) -> np.ndarray:
    """Per frame, each body child's direction in its body's own frame, (T, 2, 3, 3) for BODIES in order.

    A body's frame: x from its right child to its left child, y towards the midline child (made
    orthogonal), z = x cross y (forward).
    """
    out = []
    for j, (left, right, mid) in BODIES.items():
        frame = two_vector_frame(positions[:, left] - positions[:, right], positions[:, mid] - positions[:, j])
        local = np.einsum("tji,tkj->tki", frame, positions[:, [left, right, mid]] - positions[:, j, None])
        out.append(_unit(local))
    return np.stack(out, axis=1)


def rest_offsets(lengths: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Rest offsets (17, 3) from bone lengths (T, 16) and body directions (T, 2, 3, 3) of the clip's frames.

    Each bone gets its median length over the frames; limbs and midline bones their T-pose
    direction; a body's children the median of their measured directions in the body's frame.
    """
    length = np.nanmedian(lengths, axis=0)
    offsets = np.zeros((NUM_JOINTS, 3))
    for b, (child, _) in enumerate(BONES):
        offsets[child] = REST_DIRECTIONS[child] * length[b]
    median_dirs = _unit(np.nanmedian(directions, axis=0))
    for (_, kids), dirs in zip(BODIES.items(), median_dirs):
        for kid, d in zip(kids, dirs):
            offsets[kid] = d * np.linalg.norm(offsets[kid])
    return offsets


def _ramp(x: np.ndarray, lo: float, hi: float) -> np.ndarray:
    """Smoothstep of ``x`` from 0 at ``lo`` to 1 at ``hi``."""
    w = np.clip((x - lo) / (hi - lo), 0.0, 1.0)
    return w * w * (3 - 2 * w)


def _default_axes(
    parent_rot: np.ndarray, rest_dir: np.ndarray, rest_axis: np.ndarray, d1: np.ndarray, projected: bool
) -> np.ndarray:
    """A limb's default hinge axes (T, 3), unit and perpendicular to its upper bone's directions ``d1`` (T, 3).

    The parent's rest axis, either made perpendicular to the upper bone (``projected``: legs, whose
    knee axis stays near the pelvis's left-right axis however far the hip flexes) or carried by the
    smallest rotation onto it (arms, which swing in every direction).
    """
    carried = _apply(parent_rot, rest_axis)
    if projected:
        return _unit(carried - np.sum(carried * d1, axis=-1, keepdims=True) * d1)
    return _apply(rotation_between(_unit(_apply(parent_rot, rest_dir)), d1), carried)


def _carried_hinges(
    upper: np.ndarray,
    normal: np.ndarray,
    bent: np.ndarray,
    folded: np.ndarray,
    default: np.ndarray,
    before: np.ndarray | None,
) -> np.ndarray:
    """Hinge axes (T, 3) of a limb, continuous in time, all in its parent's frame.

    ``upper`` (T, 3) are the unit upper-bone directions, ``normal`` (T, 3) the unit normals of the
    limb's plane (upper cross lower bone), ``bent`` (T,) how far that plane is defined (0 straight,
    1 clearly bent), ``folded`` (T,) bool where the limb bends past 60 degrees, ``default`` (T, 3)
    the unit axes of a limb with no plane, perpendicular to ``upper``; ``before`` (2, 3) the upper
    bone and axis of the frame before the first (the previous chunk's last), or None to start from
    the default.

    Each frame's axis starts from the frame before's, carried by the smallest rotation of the upper
    bone, and turns about the bone towards its target by at most :data:`_MAX_TURN` (the very first
    frame, with nothing before it, takes its target). The target is
    the plane's normal where the limb is bent and the default where it is straight (blended by
    ``bent``). The normal's sign: flexion's where the limb is folded (no joint hyperextends that
    far); else the carried axis's when they are clearly parallel or opposite (a plane swinging
    about the upper arm is followed through any angle, a bend that noise flips backwards keeps its
    roll), else the default's (a bend that starts again after a straight stretch).
    """
    prev_u, axis = (upper[0], default[0]) if before is None else before
    swings = rotation_between(np.concatenate([prev_u[None], upper[:-1]]), upper)
    bent_normal, straight_default = bent[:, None] * normal, (1.0 - bent[:, None]) * default
    default_sign = np.sum(normal * default, axis=-1) >= 0
    # frame by frame on plain floats: numpy's overhead on single vectors would cost five times more
    a = axis.tolist()
    out = []
    limit = _MAX_TURN if before is not None else math.pi  # the first frame of all takes its target at once
    for swing, u, n, bn, sd, default_forward, fold in zip(
        swings.tolist(),
        upper.tolist(),
        normal.tolist(),
        bent_normal.tolist(),
        straight_default.tolist(),
        default_sign,
        folded,
    ):
        carried = [_dot(row, a) for row in swing]
        along = _dot(carried, u)
        carried = [c - along * ui for c, ui in zip(carried, u)]
        norm = max(math.sqrt(_dot(carried, carried)), 1e-12)
        carried = [c / norm for c in carried]
        side = _cross(u, carried)  # a quarter turn on from the carried axis about the bone
        agree = _dot(n, carried)
        if fold:  # bent further than any knee or elbow hyperextends: it flexes
            forward = True
        else:
            forward = agree >= 0 if abs(agree) >= _SIGN_FROM_CARRIED else default_forward
        target = [d + (b if forward else -b) for d, b in zip(sd, bn)]
        turn = min(max(math.atan2(_dot(target, side), _dot(target, carried)), -limit), limit)
        a = [math.cos(turn) * c + math.sin(turn) * si for c, si in zip(carried, side)]
        out.append(a)
        limit = _MAX_TURN
    return np.array(out).reshape(default.shape)


def _dot(a: Sequence[float], b: Sequence[float]) -> float:
    """Dot product of two 3-vectors given as sequences of floats."""
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def _cross(a: Sequence[float], b: Sequence[float]) -> list[float]:
    """Cross product of two 3-vectors given as sequences of floats."""
    return [a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0]]


def fit_rotations(
    positions: np.ndarray, offsets: np.ndarray, before: np.ndarray | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """Global joint rotations (T, 17, 3, 3) for BVH-axes positions (T, 17, 3) and rest ``offsets`` (17, 3),
    and the limbs' hinge state (4, 2, 3) after the last frame.

    Each joint is rotated from where the fitted chain has put it (not from its observed
    position), so a bone-length mismatch is not passed on to the joints below. The hinge state
    is, per limb of :data:`LIMBS` in order, the upper bone's direction and the hinge axis in the
    parent's frame; ``before`` is the state after the frame before the first (the previous
    chunk's), which the limbs' axes continue from.
    """
    T = positions.shape[0]
    rot = np.zeros((T, NUM_JOINTS, 3, 3))
    fitted = np.zeros((T, NUM_JOINTS, 3))
    state = np.zeros((len(LIMBS), 2, 3))
    x_axis = np.array([1.0, 0.0, 0.0])
    for j in range(NUM_JOINTS):
        p = PARENTS[j]
        fitted[:, j] = positions[:, j] if p < 0 else fitted[:, p] + _apply(rot[:, p], offsets[j])
        kids = CHILDREN[j]
        if j in BODIES:  # its own children only: the spine below bends against a rigid lift's thorax
            kids = BODIES[j]
            rest, seen = offsets[list(kids)], positions[:, list(kids)] - fitted[:, j, None]
            rot[:, j] = kabsch(rest, seen, _BODY_WEIGHTS)
        elif j == _SPINE:  # aimed at the thorax, rolled with the hips' and shoulders' lateral axes
            left, right, _ = BODIES[_J("thorax")]
            lateral = _unit(positions[:, left] - positions[:, right]) + _apply(rot[:, p], x_axis)
            rest = two_vector_frame(offsets[kids[0]], x_axis)
            rot[:, j] = two_vector_frame(positions[:, kids[0]] - fitted[:, j], lateral) @ rest.T
        elif j == _NECK:  # the smallest turn from the thorax that aims it at the head
            neutral = _unit(_apply(rot[:, p], offsets[kids[0]]))
            rot[:, j] = rotation_between(neutral, _unit(positions[:, kids[0]] - fitted[:, j])) @ rot[:, p]
        elif j in LIMBS:
            lower, end, axis = LIMBS[j]
            rest_axis = np.asarray(axis, dtype=np.float64)
            d1, d2 = _unit(positions[:, lower] - positions[:, j]), _unit(positions[:, end] - positions[:, lower])
            normal = np.cross(d1, d2)
            sine = np.linalg.norm(normal, axis=-1)
            default = _default_axes(rot[:, p], _unit(offsets[lower]), rest_axis, d1, projected=j in _LEGS)
            back = np.swapaxes(rot[:, p], -1, -2)  # world -> the parent's frame
            k, upper = _LIMB_ORDER.index(j), _apply(back, d1)
            local = _carried_hinges(
                upper,
                _apply(back, normal / np.maximum(sine[:, None], 1e-12)),
                _ramp(sine, *_BEND_SIN),
                np.sum(d1 * d2, axis=-1) < _FOLD_COS,
                _apply(back, default),
                None if before is None else before[k],
            )
            state[k] = upper[-1], local[-1]
            rest = two_vector_frame(offsets[lower], rest_axis)
            rot[:, j] = two_vector_frame(positions[:, lower] - fitted[:, j], _apply(rot[:, p], local)) @ rest.T
        elif j in _LOWER:  # the smallest swing from the upper bone onto the lower: no roll of its own
            upper, end, _ = _LOWER[j]
            along = _unit(_apply(rot[:, p], offsets[end]))
            rot[:, j] = rotation_between(along, _unit(positions[:, end] - fitted[:, j])) @ rot[:, p]
        else:  # leaves: wrists, ankles, head
            rot[:, j] = rot[:, p]
    return rot, state


def placed_offsets(offsets: np.ndarray, root: np.ndarray) -> np.ndarray:
    """Per-frame offsets (T, 17, 3) with the root's replaced by its position ``root`` (T, 3), for forward kinematics."""
    placed = np.broadcast_to(offsets, (len(root), NUM_JOINTS, 3)).copy()
    placed[:, 0] += root
    return placed


def _ancestors(j: int) -> list[int]:
    """Joints from the child of the root down to ``j`` (empty for the root)."""
    path = []
    while PARENTS[j] >= 0:
        path.append(j)
        j = PARENTS[j]
    return path[::-1]


_MOVERS = [p for p in range(NUM_JOINTS) if CHILDREN[p]]  # rotations that move some joint
_SINGLE = [p for p in _MOVERS if len(CHILDREN[p]) == 1]  # ... through one bone, whose own twist moves nothing


def refine_rotations(
    rot: np.ndarray, positions: np.ndarray, offsets: np.ndarray, iterations: int = 8, damping: float = 1e-2
) -> tuple[np.ndarray, np.ndarray]:
    """Global rotations (T, 17, 3, 3) and root positions (T, 3) improved by damped Gauss-Newton on the forward-kinematics error.

    Parameters are the root translation and a small rotation of each joint with children, applied
    on the left (in the world frame). The rotation about a single-child bone's own axis leaves every
    joint in place, so nothing pins it and the iterations let it drift (100-140 degree twists between
    frames): each such joint is finally turned from its given rotation by the smallest rotation onto its
    refined bone direction, keeping the given twist. ``damping`` is relative to the squared bone scale. 8
    iterations match a rigid lift to within millimetres where 4 left the thorax decimetres off when its first
    fit also aimed at the spine (docs/results.md).
    Finally the neck is turned so that the neck-to-head bone points exactly as in ``positions``.
    """
    given, rot = rot, rot.copy()
    T = len(rot)
    root = positions[:, 0].copy()
    scale2 = float(np.mean(np.sum(offsets**2, axis=-1)))
    cols = {p: 3 + 3 * i for i, p in enumerate(_MOVERS)}
    n = 3 + 3 * len(_MOVERS)
    paths = [_ancestors(j) for j in range(NUM_JOINTS)]
    for _ in range(iterations):
        pos = forward_kinematics(PARENTS, placed_offsets(offsets, root), local_rotations(rot))
        residual = (pos - positions).reshape(T, -1)  # (T, 51)
        jac = np.zeros((T, 3 * NUM_JOINTS, n))
        for j, path in enumerate(paths):
            jac[:, 3 * j : 3 * j + 3, 0:3] = np.eye(3)
            for c in path:
                p = PARENTS[c]
                jac[:, 3 * j : 3 * j + 3, cols[p] : cols[p] + 3] = -skew(_apply(rot[:, p], offsets[c]))
        jtj = np.swapaxes(jac, 1, 2) @ jac + damping * scale2 * np.eye(n)
        step = np.linalg.solve(jtj, -np.einsum("tki,tk->ti", jac, residual)[..., None])[..., 0]
        root += step[:, 0:3]
        for p, c in cols.items():
            delta = Rotation.from_rotvec(step[:, c : c + 3]).as_matrix()
            rot[:, p] = delta @ rot[:, p]
    for j in _SINGLE:  # the twist about a single-child bone moves no joint: keep the first fit's, not a drifted one
        child = offsets[CHILDREN[j][0]]
        rot[:, j] = rotation_between(_unit(_apply(given[:, j], child)), _unit(_apply(rot[:, j], child))) @ given[:, j]
    # the head's direction is the data's own (a 5 cm bone whose angle matters more than its end)
    bone = _unit(_apply(rot[:, _NECK], offsets[_HEAD]))
    rot[:, _NECK] = rotation_between(bone, _unit(positions[:, _HEAD] - positions[:, _NECK])) @ rot[:, _NECK]
    for j in range(NUM_JOINTS):  # leaves follow their parent again
        if not CHILDREN[j]:
            rot[:, j] = rot[:, PARENTS[j]]
    return rot, root


def local_rotations(global_rot: np.ndarray) -> np.ndarray:
    """Local rotations (T, 17, 3, 3), each relative to its parent, from global ones."""
    parent_rot = np.concatenate(
        [np.broadcast_to(np.eye(3), global_rot[:, :1].shape), global_rot[:, list(PARENTS[1:])]], axis=1
    )
    return np.swapaxes(parent_rot, -1, -2) @ global_rot


def hinge_alignment(rot: np.ndarray, positions: np.ndarray, offsets: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """How each limb of :data:`LIMBS` bends about its hinge: bend angles (T, 4) degrees of ``positions`` (T, 17, 3)
    and cosines (T, 4) between the hinge axis of global rotations ``rot`` (T, 17, 3, 3) on rest ``offsets`` and the
    normal of the limb's plane (upper cross lower bone; NaN where the limb is straight).

    1 where the limb flexes about its axis, negative where it bends backwards, near 0 where it bends sideways.
    """
    bend, cos = [], []
    for upper, (lower, end, rest_axis) in LIMBS.items():
        axis = (rot[:, upper] @ two_vector_frame(offsets[lower], np.asarray(rest_axis, np.float64)))[..., 1]
        d1, d2 = positions[:, lower] - positions[:, upper], positions[:, end] - positions[:, lower]
        normal = np.cross(d1, d2)
        sine = np.linalg.norm(normal, axis=-1)
        bend.append(np.degrees(np.arctan2(sine, np.sum(d1 * d2, axis=-1))))
        with np.errstate(invalid="ignore", divide="ignore"):
            cos.append(np.sum(axis * normal, axis=-1) / sine)
    return np.stack(bend, axis=1), np.stack(cos, axis=1)


def joint_steps(global_rot: np.ndarray) -> np.ndarray:
    """Angles (T - 1, 17) in degrees by which each joint's local rotation changes between consecutive frames."""
    local = local_rotations(global_rot)
    rel = np.swapaxes(local[:-1], -1, -2) @ local[1:]
    return np.degrees(np.arccos(np.clip((np.trace(rel, axis1=-2, axis2=-1) - 1) / 2, -1.0, 1.0)))
