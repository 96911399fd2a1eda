"""Joint angles of every hypothesis and their 5 / 50 / 95 % quantiles per frame.

All angles are in degrees, computed from the 17 joints (world Z up), the sides
named. Each angle lives in a fixed 360-degree range (:data:`ANGLE_RANGES`)
whose ends lie on a pose the joint cannot take (an arm raised backwards past
120 degrees, a knee or elbow bent backwards past 90), so real motion never wraps: the
same pose always reads the same number, and a series is continuous. Frames:

- pelvis frame: ``left`` from the right to the left hip, ``up`` from the pelvis
  towards the spine (made perpendicular to ``left``), ``forward = left x up``;
- trunk frame: ``left`` from the right to the left shoulder, ``up`` from the
  pelvis to the thorax (made perpendicular), ``forward = left x up``.

Angles (zero pose: standing upright, arms hanging, legs straight):

- ``<side>_hip_flexion``: thigh (hip to knee) in the pelvis's sagittal plane, 0 pointing down,
  positive forward; ``<side>_hip_abduction``: thigh in the pelvis's frontal plane, positive away
  from the midline;
- ``<side>_knee_flexion``: angle from the thigh's line to the shin, about the pelvis's left axis,
  positive bent (the shin going back), negative hyperextended;
- ``trunk_flexion``: pelvis-to-thorax line from the vertical, positive leaning forward (the pelvis's
  heading); ``trunk_lateral``: positive leaning to the left;
- ``pelvis_tilt``: pelvis-to-spine line from the vertical, positive forward; ``pelvis_obliquity``:
  hip line from the horizontal, positive with the left hip higher;
- ``<side>_shoulder_flexion``: upper arm in the trunk's sagittal plane, 0 hanging, 90 forward,
  180 overhead; ``<side>_shoulder_abduction``: in the trunk's frontal plane, positive away from
  the body;
- ``<side>_elbow_flexion``: angle between upper arm and forearm lines, 0 straight.

The ankle has no angle: our skeleton has no foot point to measure it against.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from platypose.exporters.frames import Lead, frame_chunks
from platypose.exporters.gaps import fill_frames, fill_plan
from platypose.exporters.result import LiftResult
from platypose.lifting.atomic import atomic_open
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
    "right_shoulder_flexion",
    "left_shoulder_flexion",
    "right_shoulder_abduction",
    "left_shoulder_abduction",
    "right_elbow_flexion",
    "left_elbow_flexion",
)
# Lower end of each angle's 360-degree range, [lo, lo + 360).
ANGLE_RANGES: dict[str, float] = {
    **{f"{s}_{a}": -120.0 for s in ("right", "left") for a in ("hip_flexion", "shoulder_flexion")},
    **{f"{s}_{a}": -120.0 for s in ("right", "left") for a in ("hip_abduction", "shoulder_abduction")},
    **{f"{s}_knee_flexion": -90.0 for s in ("right", "left")},
    **{f"{s}_elbow_flexion": -90.0 for s in ("right", "left")},
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


def joint_angles(joints: np.ndarray) -> np.ndarray:
    """Angles (..., 16) degrees in :data:`ANGLE_NAMES` order of joints (..., 17, 3), each in its :data:`ANGLE_RANGES`."""
    j = lambda name: joints[..., J[name], :]  # noqa: E731
    p_left, p_up, p_fwd = _frame(j("left_hip") - j("right_hip"), j("spine") - j("pelvis"))
    t_left, t_up, t_fwd = _frame(j("left_shoulder") - j("right_shoulder"), j("thorax") - j("pelvis"))
    out = {}
    for side, outward in (("right", -p_left), ("left", p_left)):
        thigh = j(f"{side}_knee") - j(f"{side}_hip")
        shin = j(f"{side}_ankle") - j(f"{side}_knee")
        out[f"{side}_hip_flexion"] = _plane_angle(thigh, -p_up, p_fwd)
        out[f"{side}_hip_abduction"] = _plane_angle(thigh, -p_up, outward)
        bend = _dot(np.cross(_unit(thigh), _unit(shin)), p_left)
        out[f"{side}_knee_flexion"] = np.degrees(np.arctan2(bend, _dot(_unit(thigh), _unit(shin))))
    for side, outward in (("right", -t_left), ("left", t_left)):
        upper = j(f"{side}_elbow") - j(f"{side}_shoulder")
        fore = j(f"{side}_wrist") - j(f"{side}_elbow")
        out[f"{side}_shoulder_flexion"] = _plane_angle(upper, -t_up, t_fwd)
        out[f"{side}_shoulder_abduction"] = _plane_angle(upper, -t_up, outward)
        out[f"{side}_elbow_flexion"] = np.degrees(np.arccos(np.clip(_dot(_unit(upper), _unit(fore)), -1.0, 1.0)))
    heading = _unit(p_fwd - _dot(p_fwd, _UP)[..., None] * _UP)
    side_axis = np.cross(_UP, heading)  # the pelvis's horizontal left
    trunk = j("thorax") - j("pelvis")
    out["trunk_flexion"] = _plane_angle(trunk, _UP, heading)
    out["trunk_lateral"] = _plane_angle(trunk, _UP, side_axis)
    out["pelvis_tilt"] = _plane_angle(j("spine") - j("pelvis"), _UP, heading)
    hips = _unit(j("left_hip") - j("right_hip"))
    out["pelvis_obliquity"] = np.degrees(np.arcsin(np.clip(_dot(hips, _UP), -1.0, 1.0)))
    angles = np.stack([out[n] for n in ANGLE_NAMES], axis=-1)
    return _LOWER_ENDS + (angles - _LOWER_ENDS) % 360.0


def person_angle_series(result: LiftResult, p: int) -> np.ndarray:
    """Angles of person ``p`` per frame, (T, A, 4): the median motion's, then the hypotheses' 5/50/95 % quantiles.

    Frames where the person is absent are filled by the rule of :mod:`exporters.gaps` (the angles of the filled
    joints); all NaN for a person never present.
    """
    T, A = result.num_frames, len(ANGLE_NAMES)
    out = np.full((T, A, len(SERIES_COLUMNS)), np.nan)
    present = result.present()[p]
    if not present.any():
        return out
    plan = fill_plan(present, result.frame_times)
    for t in frame_chunks(T):
        out[t, :, 0] = joint_angles(fill_frames(Lead(result.median, p), plan, t).astype(np.float64))
        hyp = joint_angles(fill_frames(Lead(result.hypotheses, p), plan, t, axis=1).astype(np.float64))
        out[t, :, 1:] = np.moveaxis(np.quantile(hyp, QUANTILES, axis=0), 0, -1)
    return out


def angle_series(result: LiftResult) -> dict[int, np.ndarray]:
    """Per person index with a present frame, :func:`person_angle_series`."""
    present = result.present().any(axis=1)
    return {p: person_angle_series(result, p) for p in range(result.num_persons) if present[p]}


def write_angles_csv(result: LiftResult, series: dict[int, np.ndarray], path: Path | str) -> Path:
    """Write ``person,frame,time_s,angle,median_deg,q05_deg,q50_deg,q95_deg,filled`` rows atomically.

    Every frame of each person in ``series``; ``filled`` is 1 where the person is absent (:mod:`exporters.gaps`).
    """
    path = Path(path)
    present = result.present()
    with atomic_open(path, "w", encoding="ascii", newline="\n") as f:
        f.write("person,frame,time_s,angle,median_deg,q05_deg,q50_deg,q95_deg,filled\n")
        for p, values in series.items():
            track = int(result.track_ids[p])
            for t in np.flatnonzero(np.isfinite(values[:, 0, 0])):
                time, flag = repr(float(result.frame_times[t])), int(not present[p, t])
                for a, name in enumerate(ANGLE_NAMES):
                    numbers = ",".join(f"{v:.3f}" for v in values[t, a])
                    f.write(f"{track},{t},{time},{name},{numbers},{flag}\n")
    return path
