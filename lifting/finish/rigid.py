"""Rigid people: every hypothesis keeps one shape over the whole clip, and its image positions.

The sampler's motions stretch: a bone of one hypothesis changes its length between frames by
centimetres with several views and by decimetres with one (docs/results.md), and the hips, spine,
shoulders and neck move against each other, while a person's bones do not. After lifting, each
hypothesis gets one rigid shape (:mod:`lifting.finish.rigid_shape`: one length per bone, one shape per rigid
body, the medians over the frames some view sees the person in, not a gap's guessed ones; one camera leaves
every hypothesis its own size, so shapes are per hypothesis), and every frame is moved onto it from the pelvis outwards,
each joint moving as little as it can *across the rays* of the views that see it, that is, in the
images. Where several views see a person, the sampler's lasting offsets from what they measure are first
corrected (:mod:`lifting.finish.measured`). Then

    minimise (x - x0)^T H (x - x0),  H = sum over the views seeing the joint of (I - d d^T) + ALONG_RAY I,

with ``d`` the unit ray from the view's centre to the joint. A child of a single bone goes to the
point at the bone's length from its (already placed) parent (:func:`place_on_sphere`, exact); the
three children of a body turn together about the body joint (:func:`fit_body`, damped Gauss-Newton
on the rotation from the least-squares one). One view leaves the depth along its ray nearly free
(``ALONG_RAY``), so a joint slides along its own ray and its projection stays where it was wherever
that ray comes within reach; where it does not, the joint takes the nearest reachable point.
Several views weigh the image displacement in all of them. A joint no view sees moves as little as
it can in space.

Each frame is solved alone, and with one view a limb's middle and end joints each have two places on their
rays, equal in the image: placed frame by frame, knees and elbows bend one way, then the other. So for a person
seen by one view (in most frames), each limb's branch is chosen over the whole motion first
(:mod:`lifting.finish.branches`: a Viterbi pass weighing the joint limits, the sampler's depth and the move
between frames). Where a bone lies nearly across the ray, a small change of length needs a large change of
depth: frame-to-frame jitter. So the trunk's twist is first held within what a spine allows
(:mod:`lifting.finish.twist`: a pelvis or thorax turned the other way for a few frames is turned back), then each
bone's direction and each body's rotation smoothed over time
(:func:`lifting.finish.smoothing.smooth_over_time`, ``SMOOTHNESS`` at 30 fps: a change at 5 Hz is halved,
slower ones pass), the motion rebuilt from the pelvis with the clip's shape, and each ankle that stood in the
sampler's motion put back where the sampler planted it (:mod:`lifting.finish.stance_legs`). Several views need no smoothing of the bones (it cost them
accuracy); two views' hinges follow the keypoints' noise (a far person's elbow opening and closing by 50 degrees
between frames): those are steadied (:mod:`lifting.finish.hinge_speed`); three or more measure them.
Last, every knee, elbow and head is moved inside the limits a body holds (:mod:`lifting.anatomy.limits`), and a
frame whose lowest joint the above took under the floor (and under where the sampler had it) is raised along
the floor's normal to where the sampler had it.

The median motion (:mod:`lifting.finish.representative`) is the coordinate-wise median of these hypotheses, taken
before the limits move them (a hypothesis whose knees bend backwards is left out of it, and the limits would
hide that), made a body the same way with its own shape, its elbows then bent as the hypotheses' median flexion
(:func:`answer_arms`): a median of bodies is not a body itself.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from platypose.lifting.anatomy.lengths import clamp_to_adult
from platypose.lifting.anatomy.limits import within_limits
from platypose.lifting.camera import Camera
from platypose.lifting.finish.branches import choose_branches
from platypose.lifting.finish.hinge_speed import steady_hinges
from platypose.lifting.finish.measured import measure, steady_shift
from platypose.lifting.finish.representative import agreeing, median_flexion, median_motion
from platypose.lifting.finish.rigid_shape import (
    BODY_JOINTS,
    RigidShape,
    body_offsets,
    clip_shape,
    rebuild,
)
from platypose.lifting.finish.smoothing import present_spans, smooth_frames
from platypose.lifting.finish.stance_legs import hold_stance_legs
from platypose.lifting.finish.twist import untwisted
from platypose.lifting.floor import Floor
from platypose.lifting.rotations import kabsch, rotvec_matrices, skew
from platypose.lifting.skeleton import BODIES, BONES, bone_lengths, bone_vectors
from platypose.lifting.stance import stance_ankles

ALONG_RAY = 1e-3  # weight of moving along a view's ray against moving across it (one view: depth nearly free)
BISECTIONS = 40  # halvings of the multiplier's log-range: far below a micrometre before the exact rescale
LOWEST_SHIFT = -30.0  # log10 of the smallest multiplier shift tried
BODY_STEPS = 6  # Gauss-Newton steps of a body's rotation
BODY_DAMPING = 1e-3  # of the Gauss-Newton system's mean diagonal
SMOOTHNESS = 1.0  # at 30 fps: halves a bone's or body's turn at 5 Hz (scaled with the frame rate to stay there)
MEDIAN_CHUNK = 256  # frames whose hypotheses are in memory at once for the median
HYPOTHESES_AT_ONCE = 10  # hypotheses made rigid together (their whole clip in memory)
ELBOWS = (2, 3)  # of HINGE_NAMES
MEASURING_VIEWS = 3  # views that measure every hinge: the sampler's joints need no steadying, the answer's none
ROW_CHUNK = 4096  # hypothesis-frames placed at once (each view adds 17 3x3 matrices per row)


def image_weights(joints: np.ndarray, centres: np.ndarray, seen: np.ndarray) -> np.ndarray:
    """Per joint, the quadratic form ``(M, 17, 3, 3)`` of its displacement across the rays of the views seeing it.

    ``joints`` ``(M, 17, 3)`` world metres, ``centres`` ``(C, 3)`` the views' centres, ``seen`` ``(M, 17, C)``
    whether each view sees each joint; ``ALONG_RAY`` times the identity is added so that it is never singular.
    """
    rays = joints[:, :, None, :] - centres  # (M, 17, C, 3)
    rays = rays / np.maximum(np.linalg.norm(rays, axis=-1, keepdims=True), 1e-9)
    across = np.eye(3) - rays[..., :, None] * rays[..., None, :]  # (M, 17, C, 3, 3)
    return np.einsum("mjc,mjcab->mjab", seen.astype(np.float64), across) + ALONG_RAY * np.eye(3)


def place_on_sphere(target: np.ndarray, weight: np.ndarray, centre: np.ndarray, radius: np.ndarray) -> np.ndarray:
    """The point ``x`` ``(M, 3)`` with ``|x - centre| = radius`` that minimises ``(x - target)^T weight (x - target)``.

    ``target``, ``centre`` ``(M, 3)``, ``weight`` ``(M, 3, 3)`` symmetric positive definite, ``radius`` ``(M,)``.
    The minimiser is ``y = (W + mu I)^-1 W b`` (``y = x - centre``, ``b = target - centre``) with the
    multiplier ``mu`` above minus W's smallest eigenvalue where ``|y| = radius`` (``|y|`` falls with
    ``mu``): found by bisection in the log of ``mu`` + that eigenvalue, then ``y`` is rescaled to the
    radius exactly. If even the smallest multiplier leaves ``|y|`` short (``b`` has no component along the
    smallest eigenvector), the rest is added along that eigenvector, on ``b``'s side.
    """
    values, vectors = np.linalg.eigh(weight)  # ascending (M, 3), columns (M, 3, 3)
    b = target - centre
    pulled = values * np.einsum("mab,ma->mb", vectors, b)  # W b in the eigenbasis
    low = np.full(len(b), LOWEST_SHIFT)  # log10 of mu + smallest eigenvalue
    high = np.log10(np.linalg.norm(pulled, axis=-1) / np.maximum(radius, 1e-9) + values[:, -1] + 1.0)

    def length(log_shift: np.ndarray) -> np.ndarray:
        shift = 10.0**log_shift
        return np.linalg.norm(pulled / (values - values[:, :1] + shift[:, None]), axis=-1)

    short = length(low) < radius  # the hard case: no multiplier reaches the radius
    for _ in range(BISECTIONS):
        middle = (low + high) / 2
        too_long = length(middle) > radius
        low, high = np.where(too_long, middle, low), np.where(too_long, high, middle)
    y = pulled / (values - values[:, :1] + (10.0**high)[:, None])
    rest = np.sqrt(np.maximum(radius**2 - np.sum(y[:, 1:] ** 2, -1), 0.0))
    side = np.where(np.einsum("ma,ma->m", vectors[:, :, 0], b) < 0, -1.0, 1.0)
    y[:, 0] = np.where(short, side * rest, y[:, 0])
    y = np.einsum("mab,mb->ma", vectors, y)
    y *= (radius / np.maximum(np.linalg.norm(y, axis=-1), 1e-12))[:, None]
    return centre + y


def fit_body(targets: np.ndarray, weights: np.ndarray, origin: np.ndarray, shape: np.ndarray) -> np.ndarray:
    """Rotations ``(M, 3, 3)`` turning a body's ``shape`` ``(M, 3, 3)`` (children's offsets in the body frame) about
    ``origin`` ``(M, 3)`` onto its children's ``targets`` ``(M, 3, 3)``, minimising the sum of
    ``(x - target)^T weight (x - target)`` (``weights`` ``(M, 3, 3, 3)``, one per child).

    Starts from the least-squares rotation (Kabsch) and takes ``BODY_STEPS`` damped Gauss-Newton steps.
    """
    rotation = kabsch(shape, targets - origin[:, None], np.ones(3))
    for _ in range(BODY_STEPS):
        offsets = np.einsum("mij,mkj->mki", rotation, shape)
        error = origin[:, None] + offsets - targets  # (M, 3, 3)
        jacobian = -skew(offsets)  # d offset / d small turn, (M, 3, 3, 3)
        weighted = np.swapaxes(jacobian, -1, -2) @ weights  # J^T W per child, (M, 3, 3, 3)
        normal = (weighted @ jacobian).sum(axis=1)
        gradient = (weighted @ error[..., None])[..., 0].sum(axis=1)
        damping = BODY_DAMPING * np.trace(normal, axis1=1, axis2=2)[:, None, None] / 3 + 1e-12
        turn = -np.linalg.solve(normal + damping * np.eye(3), gradient[..., None])[..., 0]
        rotation = rotvec_matrices(turn) @ rotation
    return rotation


def rigid_motion(joints: np.ndarray, shape: RigidShape, centres: np.ndarray, seen: np.ndarray) -> np.ndarray:
    """Joints ``(M, 17, 3)`` moved, pelvis outwards, onto the rigid ``shape`` (per row, leading axis M; module doc).

    ``centres`` ``(C, 3)`` are the views' centres and ``seen`` ``(M, 17, C)`` says which views see which joint.
    Rows with any NaN (absent frames, or no shape) come back as they are. ``ROW_CHUNK`` rows at a time.
    """
    joints = np.asarray(joints, np.float64)
    out = joints.copy()
    rows = np.isfinite(joints).all(axis=(1, 2)) & np.isfinite(shape.lengths).all(axis=1)
    picked = np.nonzero(rows)[0]
    for start in range(0, len(picked), ROW_CHUNK):
        some = picked[start : start + ROW_CHUNK]
        out[some] = _place_rows(joints[some], shape.rows(some), centres, seen[some])
    return out


def _place_rows(targets: np.ndarray, shape: RigidShape, centres: np.ndarray, seen: np.ndarray) -> np.ndarray:
    """:func:`rigid_motion` of rows that are all present."""
    weights = image_weights(targets, centres, seen)
    placed = targets.copy()
    for b, (child, parent) in enumerate(BONES):  # parents come before their children
        if parent in BODIES:
            kids = list(BODIES[parent])
            if child == min(kids):  # the body's first child in joint order: place all three now
                body = BODY_JOINTS.index(parent)
                turn = fit_body(targets[:, kids], weights[:, kids], placed[:, parent], shape.bodies[:, body])
                placed[:, kids] = placed[:, parent, None] + np.einsum("mij,mkj->mki", turn, shape.bodies[:, body])
        else:
            placed[:, child] = place_on_sphere(
                targets[:, child], weights[:, child], placed[:, parent], shape.lengths[:, b]
            )
    return placed


def rigid_paths(
    joints: np.ndarray,
    shape: RigidShape,
    centres: np.ndarray,
    seen: np.ndarray,
    fps: float,
    floor: Floor | None = None,
    limits: bool = True,
) -> np.ndarray:
    """Motions ``(K, T, 17, 3)`` of one person (NaN where absent) made rigid, each with its ``shape`` (lengths
    ``(K, 16)``, bodies ``(K, B, 3, 3)``; :func:`lifting.finish.rigid_shape.clip_shape`). See the module.

    ``centres`` ``(C, 3)``: the views' centres; ``seen`` ``(T, 17, C)``: which view sees which joint;
    ``fps``: the motions' frame rate; ``floor``: the floor they stand on, or None; ``limits``: knees and elbows
    held within their limits (:func:`lifting.anatomy.limits.within_limits`; False: left to the caller, which
    judges the hypotheses by them first).
    """
    joints = np.asarray(joints, np.float64)
    K, T = joints.shape[:2]
    every = RigidShape(np.repeat(shape.lengths, T, axis=0), np.repeat(shape.bodies, T, axis=0))
    views = np.broadcast_to(seen, (K, *seen.shape)).reshape(K * T, *seen.shape[1:])
    placed = rigid_motion(joints.reshape(K * T, 17, 3), every, centres, views).reshape(joints.shape)
    present = np.isfinite(placed).all(axis=(0, 2, 3))
    view_count = typical_views(seen, present)
    if present.any() and view_count < 2:  # one view: branches, then its jitter out
        view = np.argmax(seen.sum(axis=(0, 1)))
        placed = choose_branches(placed, joints, centres[view], seen[..., view], shape.lengths)
        placed = _smooth_one_view(placed, present, shape, fps)
        placed = hold_stance_legs(placed, joints, stance_ankles(joints, floor, fps, min_stance=0.0), shape.lengths)
    elif view_count < MEASURING_VIEWS:  # two views: each frame alone, its hinges then steadied (they follow the noise)
        placed = steady_hinges(within_limits(placed), present, fps)
    return _above_floor(within_limits(placed) if limits else placed, joints, floor)


def _smooth_one_view(placed: np.ndarray, present: np.ndarray, shape: RigidShape, fps: float) -> np.ndarray:
    """Rigid motions ``(K, T, 17, 3)`` of one view with each bone's direction and each body's rotation smoothed
    over the ``present`` ``(T,)`` runs of frames and the motion rebuilt on ``shape`` (see the module)."""
    smoothness = SMOOTHNESS * (fps / 30.0) ** 4  # the same cut-off in Hz at any frame rate
    lengths, bodies = shape.lengths[:, None], shape.bodies[:, None]  # (K, 1, ...): over frames
    for span in present_spans(present):
        here = placed[:, span]  # (K, t, 17, 3)
        turns = untwisted(kabsch(bodies, body_offsets(here), np.ones(3)))  # (K, t, B, 3, 3), exact: bodies are rigid
        turns = kabsch(np.eye(3), np.swapaxes(smooth_frames(turns, smoothness), -1, -2), np.ones(3))
        directions = smooth_frames(bone_vectors(here) / lengths[..., None], smoothness)
        directions /= np.maximum(np.linalg.norm(directions, axis=-1, keepdims=True), 1e-12)
        placed[:, span] = rebuild(here[..., 0, :], RigidShape(lengths, bodies), turns, directions)
    return placed


def _above_floor(placed: np.ndarray, before: np.ndarray, floor: Floor | None) -> np.ndarray:
    """Frames of ``placed`` ``(..., 17, 3)`` whose lowest joint is under the floor and under where it was in
    ``before``, raised along the floor's normal to there (to the floor if it was above it)."""
    if floor is None:
        return placed
    normal, offset = np.asarray(floor.normal), floor.offset
    lowest = (placed @ normal).min(axis=-1) + offset
    allowed = np.minimum((before @ normal).min(axis=-1) + offset, 0.0)
    return placed + np.where(lowest < allowed, allowed - lowest, 0.0)[..., None, None] * normal


def typical_views(seen: np.ndarray, present: np.ndarray) -> float:
    """How many views see a person's joint in a typical frame: the median over the ``present`` ``(T,)`` frames and
    joints of ``seen`` ``(T, 17, C)`` summed over views (0 if none is present)."""
    return float(np.median(seen[present].sum(axis=-1))) if present.any() else 0.0


def answer_arms(answer: np.ndarray, flexion: np.ndarray, fps: float, views: float) -> np.ndarray:
    """The rigid answer ``(T, 17, 3)`` of a person seen by ``views`` views (:func:`typical_views`) with its elbows bent
    as the hypotheses' median ``flexion`` ``(T, 4)`` (:func:`lifting.finish.representative.median_flexion`),
    steadied over time as every hinge is, where it is known; then held within the limits. Its knees keep the bend
    its planted feet give them. ``MEASURING_VIEWS`` or more views measure the answer's wrists: it is returned as
    it is."""
    if views >= MEASURING_VIEWS:
        return answer
    frames = np.isfinite(answer).all(axis=(1, 2)) & np.isfinite(flexion[:, list(ELBOWS)]).all(axis=1)
    steady = steady_hinges(answer[None], frames, fps, np.nan_to_num(flexion)[None], ELBOWS)[0]
    return np.where(frames[:, None, None], within_limits(np.where(frames[:, None, None], steady, 0.0)), answer)


def person_shape(motions: np.ndarray, views: int, measured: np.ndarray | None = None) -> RigidShape:
    """The rigid shape of motions ``(K, T, 17, 3)`` (:func:`lifting.finish.rigid_shape.clip_shape`) over the
    ``measured`` ``(T,)`` frames, those some view sees (None, or none measured: every frame); from one view, its
    limb bones held to adult lengths (:mod:`lifting.anatomy.lengths`): a camera alone cannot measure them, and
    the sampler's guesses ran to 12 cm forearms. Several views measure every bone: their lengths stand.

    Frames of a gap no view sees are the prior's guess: a shape taken over them too added 1-2 mm to the seen frames
    of one-view eval windows with a 1 s gap (docs/results.md, issue 49)."""
    if measured is not None and measured.any():
        motions = np.where(measured[:, None, None], motions, np.nan)
    shape = clip_shape(motions)
    return shape if views > 1 else RigidShape(clamp_to_adult(shape.lengths), shape.bodies)


def rigid_person(
    hypotheses,
    median,
    keypoints: np.ndarray,
    cameras: Sequence[Camera],
    person: int,
    fps: float,
    floor: Floor | None = None,
) -> dict[str, float]:
    """Make person ``person``'s hypotheses ``(P, N, T, 17, 3)`` and median ``(P, T, 17, 3)`` rigid, in place, none
    of their frames taken under ``floor`` (None: no floor).

    Arrays may be memory maps: ``HYPOTHESES_AT_ONCE`` hypotheses, or ``MEDIAN_CHUNK`` frames of all, are in
    memory at a time. ``keypoints`` ``(C, T, P, 17, 3)`` say which view sees which joint (confidence > 0). The median is
    recomputed from the rigid hypotheses, then made rigid with its own shape. Returns, for the median
    motion, the largest change of a bone's length against its clip length as the sampler gave it
    (``stretch_m``) and the median and largest displacement of a joint by this module (``moved_m``,
    ``moved_max_m``).
    """
    N, T = hypotheses.shape[1:3]
    centres = np.stack([cam.center for cam in cameras])
    seen = np.moveaxis(keypoints[:, :, person, :, 2] > 0, 0, -1)  # (T, 17, C)
    measured = seen.any(axis=(1, 2))  # frames some view sees: the shape is theirs
    before = np.array(median[person], np.float64)  # (T, 17, 3)
    stretch = np.abs(bone_lengths(before) - clip_shape(before).lengths)
    shift = 0.0 if len(cameras) < 2 else steady_shift(before, measure(keypoints[:, :, person], cameras), fps)
    for start in range(0, N, HYPOTHESES_AT_ONCE):
        n = slice(start, min(start + HYPOTHESES_AT_ONCE, N))
        motions = np.asarray(hypotheses[person, n], np.float64) + shift
        shape = person_shape(motions, len(cameras), measured)
        hypotheses[person, n] = rigid_paths(motions, shape, centres, seen, fps, floor, limits=False)
    members = np.zeros((N, T), dtype=bool)
    for start in range(0, T, MEDIAN_CHUNK):
        t = slice(start, min(start + MEDIAN_CHUNK, T))
        members[:, t] = agreeing(np.asarray(hypotheses[person, :, t], np.float64))
        median[person, t] = median_motion(np.asarray(hypotheses[person, :, t], np.float64), members[:, t])
    for start in range(0, N, HYPOTHESES_AT_ONCE):  # the median judged them (knees bent backwards) before this
        n = slice(start, min(start + HYPOTHESES_AT_ONCE, N))
        hypotheses[person, n] = within_limits(np.asarray(hypotheses[person, n], np.float64))
    flexion = np.concatenate(
        [
            median_flexion(
                np.asarray(hypotheses[person, :, start : start + MEDIAN_CHUNK], np.float64),
                members[:, start : start + MEDIAN_CHUNK],
            )
            for start in range(0, T, MEDIAN_CHUNK)
        ]
    )
    middle = np.asarray(median[person], np.float64)[None]
    middle = rigid_paths(middle, person_shape(middle, len(cameras), measured), centres, seen, fps, floor)[0]
    median[person] = answer_arms(middle, flexion, fps, typical_views(seen, np.isfinite(middle).all(axis=(1, 2))))
    moved = np.linalg.norm(np.asarray(median[person], np.float64) - before, axis=-1)
    moved = moved[np.isfinite(moved)]
    return {
        "stretch_m": round(float(np.nanmax(stretch, initial=0.0)), 4),
        "moved_m": round(float(np.median(moved)) if moved.size else 0.0, 4),
        "moved_max_m": round(float(moved.max(initial=0.0)), 4),
    }
