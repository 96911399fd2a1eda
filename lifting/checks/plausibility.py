"""Plausibility of each person's hypotheses: under the floor, sliding feet, spread over metres, a body no human has.

Measured on the lifted hypotheses ``(P, N, T, 17, 3)`` (world metres) after lifting; a flag says a
person's hypotheses stay implausible, so a user knows which persons not to trust:

- ``under floor``: more than ``UNDER_SHARE`` of hypothesis-frames have their lowest ankle more than
  ``UNDER_FLOOR`` below the floor;
- ``sliding``: stance ankles (:func:`platypose.lifting.stance.stance_ankles`: each hypothesis's lower ankle within
  ``STANCE_BAND`` of its own standing height at that time, for at least ``MIN_STANCE`` on end, in two consecutive
  frames) move along the floor by more than ``SLIDE`` per frame (median). A foot that is low for less than
  ``MIN_STANCE`` is taking off, landing or swinging past, as in hops, jumping jacks and running, not standing;
- ``spread``: the hypotheses' pelvises lie more than ``SPREAD`` from their median (90 % of them, median
  over frames);
- ``bone lengths`` and ``joint angles``: the median motion's limb bones outside human lengths, its joints outside
  human range (:mod:`lifting.checks.body`);
- ``behind camera``: in more than ``BEHIND_SHARE`` of the frames a camera sees a person (4 joints or more), the median
  motion's pelvis lies less than ``MIN_DEPTH`` in front of that camera, or behind it (camera-frame z). No camera sees
  what is behind it: keypoints upside down, or all at one pixel, can still be reprojected by a body placed behind
  the lens (the projection flips twice), so the depth's sign, not the reprojection, tells.
- ``hinge jumps``: its signed knee or elbow flexion changing faster than a body turns a hinge, with the frames.

Being seen by fewer than two cameras in most frames present is not a flag but the report's ``one_view``. The report's
``flag_text`` says every flag with its figure in one sentence (:func:`lifting.checks.flags.flag_text`).

Not everyone stands on the floor: a hypothesis's standing height at a time
(:func:`platypose.lifting.stance.standing_heights`) is the low ``STANDING_QUANTILE`` of its lower ankle within
``SUPPORT_WINDOW`` either side, and the person's support
(:func:`support_levels`: the median hypothesis's standing height less ``ANKLE_HEIGHT``, in levels) says where
they stand: on the floor, on a roof or a platform, or below the floor (a lower floor than the calibration's z = 0,
which several views can measure).
"""

from __future__ import annotations

from collections.abc import Iterable, Sequence

import numpy as np

from platypose.lifting.camera import Camera
from platypose.lifting.checks.body import angles_out_of_range, bone_lengths_out_of_range, hinge_jumps
from platypose.lifting.checks.flags import flag_text
from platypose.lifting.checks.thresholds import MIN_LEVEL, SLIDE, SPREAD, SUPPORT_STEP, UNDER_FLOOR, UNDER_SHARE
from platypose.lifting.floor import Floor
from platypose.lifting.stance import ANKLE_HEIGHT, ANKLES, WORLD_UP, ankle_heights, stance_ankles, standing_heights

MIN_DEPTH = 0.1  # metres in front of a camera's centre: a person seen by it is farther
BEHIND_SHARE = 0.05  # of the camera-frames seeing a person

CHUNK = 1024  # frames read at a time


def lowest_ankle(hypotheses: np.ndarray, floor: Floor | None) -> np.ndarray:
    """Height of the lower ankle above the floor (or world z = 0), ``(..., T)`` for joints ``(..., T, 17, 3)``."""
    return ankle_heights(hypotheses, floor).min(axis=-1)


def stance_slides(hypotheses: np.ndarray, floor: Floor | None, fps: float = 30.0) -> np.ndarray:
    """Moves along the floor (m) of stance ankles between consecutive frames, pooled over hypotheses ``(N, T, 17, 3)``
    at ``fps`` frames per second.

    A move counts when the same ankle stands (:func:`platypose.lifting.stance.stance_ankles`) in both frames.
    """
    normal = np.asarray(floor.normal if floor is not None else WORLD_UP)
    ankles = hypotheses[..., list(ANKLES), :]  # (N, T, 2, 3)
    if ankles.shape[1] < 2:
        return np.zeros(0)
    stance = stance_ankles(hypotheses, floor, fps)
    step = np.diff(ankles, axis=1)
    along = np.linalg.norm(step - (step @ normal)[..., None] * normal, axis=-1)  # (N, T-1, 2)
    both = stance[:, 1:] & stance[:, :-1] & np.isfinite(along)
    return along[both]


def support_levels(support: np.ndarray, fps: float) -> list[dict]:
    """Levels of a person's support heights ``(T,)`` (metres above the floor, NaN where absent): runs of frames
    within ``SUPPORT_STEP`` of their running mean, held at least ``MIN_LEVEL``; each ``{"first_frame", "last_frame",
    "height_m"}`` (the run's median)."""
    runs: list[list[int]] = []
    mean = np.nan
    for t, height in enumerate(np.asarray(support, dtype=np.float64)):
        if not np.isfinite(height):
            mean = np.nan
            continue
        if not (abs(height - mean) <= SUPPORT_STEP) or runs[-1][-1] != t - 1:
            runs.append([])
            mean = height
        runs[-1].append(t)
        mean += (height - mean) / len(runs[-1])
    return [
        {"first_frame": run[0], "last_frame": run[-1], "height_m": round(float(np.median(support[run])), 3)}
        for run in runs
        if len(run) >= MIN_LEVEL * fps
    ]


def person_plausibility(
    blocks: Iterable[np.ndarray], views_seen: np.ndarray, floor: Floor | None, fps: float = 30.0
) -> dict:
    """Figures and flags of one person: their hypotheses as consecutive blocks of frames ``(N, t, 17, 3)`` (NaN
    where absent) at ``fps``, ``views_seen`` ``(T,)`` the number of cameras seeing the person per frame."""
    under, counted, slides, spreads, lows, support = 0, 0, [], [], [], []
    for block in blocks:
        block = np.asarray(block, dtype=np.float64)
        present = np.isfinite(block).all(axis=(0, -1, -2))
        lower = np.where(present, lowest_ankle(block, floor), np.nan)  # (N, t)
        support.append(np.median(standing_heights(lower, fps), axis=0) - ANKLE_HEIGHT)
        slides.append(stance_slides(np.where(present[:, None, None], block, np.nan), floor, fps))
        block, lower = block[:, present], lower[:, present]
        if block.shape[1] == 0:
            continue
        if floor is not None:
            under, counted = under + int((lower < -UNDER_FLOOR).sum()), counted + lower.size
            lows.append(np.median(lower, axis=0))
        pelvis = block[:, :, 0]
        radius = np.linalg.norm(pelvis - np.median(pelvis, axis=0), axis=-1)  # (N, t)
        spreads.append(np.percentile(radius, 90, axis=0))
    present = np.isfinite(np.asarray(views_seen, dtype=np.float64)) & (np.asarray(views_seen) > 0)
    report: dict = {"frames": int(sum(len(s) for s in spreads))}
    flags: list[str] = []
    if not spreads:
        return {**report, "flags": flags}
    if floor is not None:
        report["under_floor_share"] = under / max(counted, 1)
        report["lowest_ankle_median_m"] = float(np.median(np.concatenate(lows)))
        report["support"] = support_levels(np.concatenate(support), fps)
        if report["under_floor_share"] > UNDER_SHARE:
            flags.append("under floor")
    pooled = np.concatenate(slides)
    report["stance_slide_median_m"] = float(np.median(pooled)) if len(pooled) else 0.0
    if report["stance_slide_median_m"] > SLIDE:
        flags.append("sliding")
    report["pelvis_spread_m"] = float(np.median(np.concatenate(spreads)))
    if report["pelvis_spread_m"] > SPREAD:
        flags.append("spread")
    report["several_views_share"] = float(np.mean(np.asarray(views_seen)[present] >= 2)) if present.any() else 0.0
    report["one_view"] = report["several_views_share"] < 0.5
    return {**report, "flags": flags}


def body_plausibility(report: dict, median: np.ndarray, fps: float = 30.0) -> dict:
    """``report`` with the body checks of the person's median motion ``(T, 17, 3)`` at ``fps`` (:mod:`lifting.checks.body`):
    ``bone_lengths_out``, ``angles_out`` and ``hinge_jumps`` (empty when human), flagged ``bone lengths``, ``joint
    angles`` and ``hinge jumps``. Bones are checked only where several views measured them: one view's limbs are the
    prior's guess, held to adult lengths."""
    bones = {} if report.get("one_view") else bone_lengths_out_of_range(median)
    angles = angles_out_of_range(median)
    jumps = hinge_jumps(median, fps)
    flags = list(report["flags"]) + ["bone lengths"] * bool(bones) + ["joint angles"] * bool(angles)
    flags += ["hinge jumps"] * bool(jumps)
    return {**report, "bone_lengths_out": bones, "angles_out": angles, "hinge_jumps": jumps, "flags": flags}


def camera_depths(median: np.ndarray, seen: np.ndarray, cameras: Sequence[Camera]) -> dict:
    """``behind_camera_share`` and ``pelvis_depth_median_m`` of a person's median motion ``(T, 17, 3)`` in the
    frames each camera sees them (``seen`` ``(C, T)`` bool): camera-frame z of the pelvis; empty when no camera
    sees them in a frame with a pelvis."""
    depths = []
    pelvis = median[:, 0]
    finite = np.isfinite(pelvis).all(axis=-1)
    for camera, frames in zip(cameras, seen):
        on = frames & finite
        if on.any():
            depths.append(pelvis[on] @ np.asarray(camera.R, np.float64)[2] + float(camera.t[2]))
    if not depths:
        return {}
    z = np.concatenate(depths)
    return {"behind_camera_share": float(np.mean(z < MIN_DEPTH)), "pelvis_depth_median_m": float(np.median(z))}


def plausibility(
    hypotheses,
    keypoints: np.ndarray,
    floor: Floor | None,
    fps: float = 30.0,
    chunk: int = CHUNK,
    median=None,
    cameras: Sequence[Camera] | None = None,
) -> list[dict]:
    """:func:`person_plausibility` of every person: hypotheses ``(P, N, T, 17, 3)`` (an array, or anything indexed
    like one, read ``chunk`` frames at a time) at ``fps``, keypoints ``(C, T, P, 17, 3)`` (x, y, confidence) on the
    same frames; given their ``median`` ``(P, T, 17, 3)``, with its :func:`body_plausibility` too, and with the
    ``cameras`` too, its :func:`camera_depths` (flagged ``behind camera``). Each report ends with its ``flag_text``
    (:func:`lifting.checks.flags.flag_text`)."""
    by_camera = (np.nan_to_num(keypoints[..., 2]) > 0).sum(axis=-1) >= 4  # (C, T, P) cameras seeing 4+ joints
    seen = by_camera.sum(axis=0)  # (T, P)
    P, T = hypotheses.shape[0], hypotheses.shape[2]
    reports = []
    for p in range(P):
        blocks = (hypotheses[p, :, start : start + chunk] for start in range(0, T, chunk))
        report = person_plausibility(blocks, seen[:, p], floor, fps)
        if median is not None and report["frames"]:
            report = body_plausibility(report, np.asarray(median[p], np.float64), fps)
            if cameras is not None:
                report.update(camera_depths(np.asarray(median[p], np.float64), by_camera[:, :, p], cameras))
                if report.get("behind_camera_share", 0.0) > BEHIND_SHARE:
                    report["flags"] = [*report["flags"], "behind camera"]
        reports.append({**report, "flag_text": flag_text(report)})
    return reports
