"""Joint angles of every hypothesis and their 5 / 50 / 95 % quantiles per frame, continuous in time.

All angles are in degrees, computed from the 17 joints (world Z up), the sides
named. Frames:

- pelvis frame: ``left`` from the right to the left hip, ``up`` from the pelvis
  towards the spine (made perpendicular to ``left``), ``forward = left x up``;
- trunk frame: ``left`` from the right to the left shoulder, ``up`` from the
  pelvis to the thorax (made perpendicular), ``forward = left x up``;
  ``outward`` is ``left`` for the left side and ``-left`` for the right.

Angles (zero pose: standing upright, arms hanging, legs straight):

- ``<side>_hip_flexion``: thigh (hip to knee) in the pelvis's sagittal plane, 0 pointing down,
  positive forward; ``<side>_hip_abduction``: the thigh's angle out of that plane, positive away
  from the midline (flexion, then abduction about the floating axis, as Grood and Suntay: no
  flip when the thigh points forward, as sitting);
- ``<side>_knee_flexion``: angle between the thigh and shin lines, 0 straight, negative where the knee bends
  backwards (hyperextended) about the hinge axis the thigh carries (:mod:`lifting.anatomy.hinges`; the sign of the
  ``.mot``'s ``knee_<s>_flexion``);
- ``trunk_flexion``: pelvis-to-thorax line from the vertical, positive leaning forward (the pelvis's
  heading); ``trunk_lateral``: its angle out of the heading's vertical plane, positive to the left;
- ``pelvis_tilt``: pelvis-to-spine line from the vertical, positive forward; ``pelvis_obliquity``:
  hip line from the horizontal, positive with the left hip higher;
- shoulders, after ISB (Wu et al. 2005) in the trunk frame: ``<side>_shoulder_plane`` the plane of
  elevation (0 raising the arm sideways, 90 forwards, negative backwards),
  ``<side>_shoulder_elevation`` the upper arm's angle from hanging (0 hanging, 90 horizontal,
  180 overhead), ``<side>_shoulder_rotation`` the axial rotation, positive internal: the forearm's
  turn about the upper arm from where the forearm pointing forward with the arm hanging is carried
  by the shortest swing of the arm (continuous through hanging, unlike ISB's third Euler angle,
  which differs from it by the plane of elevation);
- ``<side>_elbow_flexion``: angle between upper arm and forearm lines, 0 straight, negative where the forearm
  bends backwards about the hinge axis the upper arm carries (:mod:`lifting.anatomy.hinges`, the ``.mot``'s sign): where
  the axial rotation would be past 90 degrees either way; the rotation then reads half a turn from that (the
  model's: the same pose, its elbow bent the other way).

A single pose reads each angle in a fixed 360-degree range (:data:`ANGLE_RANGES`) whose ends lie on
a pose the joint cannot take. Over time (:func:`continue_angles`) every angle is unwrapped (it
continues past the range's end instead of jumping by 360), and the two angles a pose cannot define,
the plane of elevation of a hanging arm and the axial rotation of a straight elbow, hold their
previous value there and follow the pose as it defines them again (fully above 30 degrees of
elevation or elbow flexion, not at all below 10; by at most 40 degrees per frame: an arm swinging
through hanging turns its plane from forwards to backwards over a few frames, not in one).

The ankle has no angle: our skeleton has no foot point to measure it against.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from platypose.exporters.frames import Lead, frame_chunks
from platypose.exporters.gaps import fill_frames, fill_plan
from platypose.exporters.result import LiftResult
from platypose.lifting.anatomy.hinges import HINGE_NAMES, signed_flexion
from platypose.lifting.files.atomic import atomic_open
from platypose.lifting.skeleton import JOINT_INDEX as J

ANGLE_NAMES: tuple[str, ...] = (
    "right_hip_flexion",
    "left_hip_flexion",
    "right_hip_abduction",
    "left_hip_abduction",
    "right_knee_flexion",
    "left_knee_flexion",
    "trunk_flexion",
    "trunk_lateral",
    "pelvis_tilt",
    "pelvis_obliquity",
    "right_shoulder_plane",
    "left_shoulder_plane",
    "right_shoulder_elevation",
    "left_shoulder_elevation",
    "right_shoulder_rotation",
    "left_shoulder_rotation",
    "right_elbow_flexion",
    "left_elbow_flexion",
)
# Lower end of each angle's 360-degree range, [lo, lo + 360).
ANGLE_RANGES: dict[str, float] = {
    **{f"{s}_{a}": -120.0 for s in ("right", "left") for a in ("hip_flexion", "hip_abduction")},
    **{f"{s}_shoulder_plane": -150.0 for s in ("right", "left")},
    **{f"{s}_shoulder_elevation": -90.0 for s in ("right", "left")},
    **{f"{s}_shoulder_rotation": -180.0 for s in ("right", "left")},
    **{f"{s}_knee_flexion": -180.0 for s in ("right", "left")},
    **{f"{s}_elbow_flexion": -180.0 for s in ("right", "left")},
    "trunk_flexion": -120.0,
    "trunk_lateral": -180.0,
    "pelvis_tilt": -180.0,
    "pelvis_obliquity": -180.0,
}
_LOWER_ENDS = np.array([ANGLE_RANGES[n] for n in ANGLE_NAMES])
QUANTILES = (0.05, 0.5, 0.95)
# Columns of a person's series: the angle of the median motion, then the hypotheses' quantiles.
SERIES_COLUMNS = ("median", "q05", "q50", "q95")
_UP = np.array([0.0, 0.0, 1.0])
# Angles a pose may leave undefined, and the angle that defines each: its weight ramps from 0 to 1 between
# these degrees of the definer (continue_angles).
_HELD = {
    **{f"{s}_shoulder_plane": f"{s}_shoulder_elevation" for s in ("right", "left")},
    **{f"{s}_shoulder_rotation": f"{s}_elbow_flexion" for s in ("right", "left")},
}
_HOLD_BELOW, _FOLLOW_ABOVE = 10.0, 30.0
_HELD_STEP = 40.0  # ... and by at most this many degrees per frame


def _unit(v: np.ndarray) -> np.ndarray:
    return v / np.maximum(np.linalg.norm(v, axis=-1, keepdims=True), 1e-12)


def _dot(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.sum(a * b, axis=-1)


def _frame(left: np.ndarray, up: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit (left, up, forward) from a left vector and an up vector (made perpendicular)."""
    left = _unit(left)
    up = _unit(up - _dot(up, left)[..., None] * left)
    return left, up, np.cross(left, up)


def _plane_angle(v: np.ndarray, zero: np.ndarray, positive: np.ndarray) -> np.ndarray:
    """Angle of ``v`` from ``zero`` towards ``positive`` in their plane, degrees in (-180, 180]."""
    return np.degrees(np.arctan2(_dot(v, positive), _dot(v, zero)))


def _axial_rotation(
    upper: np.ndarray, fore: np.ndarray, up: np.ndarray, forward: np.ndarray, outward: np.ndarray
) -> np.ndarray:
    """Internal rotation (...) degrees of unit upper arms ``upper`` with unit forearms ``fore`` (..., 3): the
    forearm's angle about the arm from ``forward`` carried by the shortest swing from hanging (``-up``)."""
    axis = np.cross(-up, upper)
    sin = np.linalg.norm(axis, axis=-1, keepdims=True)
    axis = axis / np.maximum(sin, 1e-12)
    cos = -_dot(up, upper)[..., None]

    def swung(v: np.ndarray) -> np.ndarray:  # Rodrigues: v turned about axis by the elevation
        return v * cos + np.cross(axis, v) * sin + axis * _dot(axis, v)[..., None] * (1.0 - cos)

    zero, medial = swung(forward), swung(-outward)
    across = fore - _dot(fore, upper)[..., None] * upper
    return np.degrees(np.arctan2(_dot(across, medial), _dot(across, zero)))


def joint_angles(joints: np.ndarray) -> np.ndarray:
    """Angles (..., 16) degrees in :data:`ANGLE_NAMES` order of joints (..., 17, 3), each in its :data:`ANGLE_RANGES`."""
    j = lambda name: joints[..., J[name], :]  # noqa: E731
    p_left, p_up, p_fwd = _frame(j("left_hip") - j("right_hip"), j("spine") - j("pelvis"))
    t_left, t_up, t_fwd = _frame(j("left_shoulder") - j("right_shoulder"), j("thorax") - j("pelvis"))
    out = {}
    for side, outward in (("right", -p_left), ("left", p_left)):
        thigh = j(f"{side}_knee") - j(f"{side}_hip")
        out[f"{side}_hip_flexion"] = _plane_angle(thigh, -p_up, p_fwd)
        out[f"{side}_hip_abduction"] = np.degrees(np.arcsin(np.clip(_dot(_unit(thigh), outward), -1.0, 1.0)))
    for side, outward in (("right", -t_left), ("left", t_left)):
        upper = _unit(j(f"{side}_elbow") - j(f"{side}_shoulder"))
        fore = _unit(j(f"{side}_wrist") - j(f"{side}_elbow"))
        out[f"{side}_shoulder_plane"] = np.degrees(np.arctan2(_dot(upper, t_fwd), _dot(upper, outward)))
        out[f"{side}_shoulder_elevation"] = np.degrees(np.arccos(np.clip(-_dot(upper, t_up), -1.0, 1.0)))
        out[f"{side}_shoulder_rotation"] = _axial_rotation(upper, fore, t_up, t_fwd, outward)
    for name, flexion in zip(HINGE_NAMES, np.moveaxis(signed_flexion(joints), -1, 0)):
        out[f"{name}_flexion"] = flexion
    for side in ("right", "left"):  # an elbow bent backwards: the upper arm turned half a turn the other way
        rotation = out[f"{side}_shoulder_rotation"]
        out[f"{side}_shoulder_rotation"] = np.where(
            out[f"{side}_elbow_flexion"] < 0, rotation - np.copysign(180.0, rotation), rotation
        )
    heading = _unit(p_fwd - _dot(p_fwd, _UP)[..., None] * _UP)
    side_axis = np.cross(_UP, heading)  # the pelvis's horizontal left
    trunk = j("thorax") - j("pelvis")
    out["trunk_flexion"] = _plane_angle(trunk, _UP, heading)
    out["trunk_lateral"] = np.degrees(np.arcsin(np.clip(_dot(_unit(trunk), side_axis), -1.0, 1.0)))
    out["pelvis_tilt"] = _plane_angle(j("spine") - j("pelvis"), _UP, heading)
    hips = _unit(j("left_hip") - j("right_hip"))
    out["pelvis_obliquity"] = np.degrees(np.arcsin(np.clip(_dot(hips, _UP), -1.0, 1.0)))
    angles = np.stack([out[n] for n in ANGLE_NAMES], axis=-1)
    return _LOWER_ENDS + (angles - _LOWER_ENDS) % 360.0


_HINGES_AT = np.array([ANGLE_NAMES.index(f"{name}_flexion") for name in HINGE_NAMES])  # signed, never unwrapped
_HELD_AT = np.array([ANGLE_NAMES.index(a) for a in _HELD])
_DEFINED_BY = np.array([ANGLE_NAMES.index(d) for d in _HELD.values()])


def continue_angles(raw: np.ndarray, previous: np.ndarray | None = None) -> np.ndarray:
    """Angles (..., T, A) of :func:`joint_angles` made continuous over their frames (axis -2).

    Each frame takes the equivalent of its angle (modulo 360) nearest the frame before's, but for the signed knee
    and elbow flexion, which stay in (-180, 180] (a sign change is a bend the other way); the plane of
    elevation and the axial rotation move towards theirs only as far as elevation and elbow flexion define
    them (see the module's docstring). ``previous`` (..., A) is the frame before the first (a previous
    chunk's last), or None to start from the first frame as it is.
    """
    out = np.empty_like(raw)
    prev = previous
    for t in range(raw.shape[-2]):
        now = raw[..., t, :]
        if prev is None:
            prev = now.copy()
        else:
            step = (now - prev + 180.0) % 360.0 - 180.0
            step[..., _HINGES_AT] = now[..., _HINGES_AT] - prev[..., _HINGES_AT]
            ramp = np.clip((np.abs(now[..., _DEFINED_BY]) - _HOLD_BELOW) / (_FOLLOW_ABOVE - _HOLD_BELOW), 0.0, 1.0)
            step[..., _HELD_AT] = np.clip(ramp * step[..., _HELD_AT], -_HELD_STEP, _HELD_STEP)
            prev = prev + step
        out[..., t, :] = prev
    return out


def person_angle_series(result: LiftResult, p: int) -> np.ndarray:
    """Angles of person ``p`` per frame, (T, A, 4): the median motion's, then the hypotheses' 5/50/95 % quantiles.

    Frames where the person is absent are filled by the rule of :mod:`exporters.gaps` (the angles of the filled
    joints); all NaN for a person never present. Every series (the median's, each hypothesis's before its
    quantiles are taken) is continuous in time (:func:`continue_angles`); a hypothesis's angle counts the turns
    nearest the median's (within 180 degrees of it) before the quantiles are taken.
    """
    T, A = result.num_frames, len(ANGLE_NAMES)
    out = np.full((T, A, len(SERIES_COLUMNS)), np.nan)
    present = result.present()[p]
    if not present.any():
        return out
    plan = fill_plan(present, result.frame_times)
    median = hyp = None
    for t in frame_chunks(T):
        raw = joint_angles(fill_frames(Lead(result.median, p), plan, t).astype(np.float64))
        median = continue_angles(raw, None if median is None else median[-1])
        raw = joint_angles(fill_frames(Lead(result.hypotheses, p), plan, t, axis=1).astype(np.float64))
        hyp = continue_angles(raw, None if hyp is None else hyp[:, -1])  # (N, t, A)
        near = median + (hyp - median + 180.0) % 360.0 - 180.0  # each turn count nearest the median's
        out[t, :, 0] = median
        out[t, :, 1:] = np.moveaxis(np.quantile(near, QUANTILES, axis=0), 0, -1)
    return out


def angle_series(result: LiftResult) -> dict[int, np.ndarray]:
    """Per person index with a present frame, :func:`person_angle_series`."""
    present = result.present().any(axis=1)
    return {p: person_angle_series(result, p) for p in range(result.num_persons) if present[p]}


def write_angles_csv(result: LiftResult, series: dict[int, np.ndarray], path: Path | str) -> Path:
    """Write ``person,frame,time_s,angle,median_deg,q05_deg,q50_deg,q95_deg,filled`` rows atomically.

    Every frame of each person in ``series``; ``filled`` is 1 where the person is absent or unseen (filled by the
    prior; :mod:`exporters.gaps`).
    """
    path = Path(path)
    filled = ~result.present() | ~result.seen()
    with atomic_open(path, "w", encoding="ascii", newline="\n") as f:
        f.write("person,frame,time_s,angle,median_deg,q05_deg,q50_deg,q95_deg,filled\n")
        for p, values in series.items():
            track = int(result.track_ids[p])
            for t in np.flatnonzero(np.isfinite(values[:, 0, 0])):
                time, flag = repr(float(result.frame_times[t])), int(filled[p, t])
                for a, name in enumerate(ANGLE_NAMES):
                    numbers = ",".join(f"{v:.3f}" for v in values[t, a])
                    f.write(f"{track},{t},{time},{name},{numbers},{flag}\n")
    return path
