"""Plausibility of each person's hypotheses: under the floor, sliding feet, spread over metres, one view only.

Measured on the lifted hypotheses ``(P, N, T, 17, 3)`` (world metres) after lifting; a flag says a
person's hypotheses stay implausible, so a user knows which persons not to trust:

- ``under floor``: more than ``UNDER_SHARE`` of hypothesis-frames have their lowest ankle more than
  ``UNDER_FLOOR`` below the floor;
- ``sliding``: stance ankles (each hypothesis's lower ankle within ``STANCE_BAND`` of its own standing
  height, in two consecutive frames) move along the floor by more than ``SLIDE`` per frame (median);
- ``spread``: the hypotheses' pelvises lie more than ``SPREAD`` from their median (90 % of them, median
  over frames);
- ``one view``: the person is seen by fewer than two cameras in most frames they are present.
"""

from __future__ import annotations

from collections.abc import Iterable

import numpy as np

from platypose.lifting.floor import ANKLES, Floor

UNDER_FLOOR = 0.03  # metres below the floor
UNDER_SHARE = 0.01  # share of hypothesis-frames
SLIDE = 0.02  # metres per frame
SPREAD = 1.0  # metres
STANCE_BAND = 0.05  # metres above a hypothesis's standing height (5th percentile of its lower ankle)

CHUNK = 1024  # frames read at a time
UP = Floor((0.0, 0.0, 1.0), 0.0, "world")  # heights along world z when no floor is known


def lowest_ankle(hypotheses: np.ndarray, floor: Floor | None) -> np.ndarray:
    """Height of the lower ankle above the floor (or world z = 0), ``(..., T)`` for joints ``(..., T, 17, 3)``."""
    return (floor or UP).height(hypotheses[..., list(ANKLES), :]).min(axis=-1)


def stance_slides(hypotheses: np.ndarray, floor: Floor | None) -> np.ndarray:
    """Moves along the floor (m) of stance ankles between consecutive frames, pooled over hypotheses ``(N, T, 17, 3)``.

    A hypothesis's stance ankle is its lower ankle while within ``STANCE_BAND`` of its standing height (the 5th
    percentile of its lower ankle's height); a move counts when the same ankle stands in both frames.
    """
    plane = floor or UP
    normal = np.asarray(plane.normal)
    ankles = hypotheses[..., list(ANKLES), :]  # (N, T, 2, 3)
    height = plane.height(ankles)  # (N, T, 2)
    if height.shape[1] < 2:
        return np.zeros(0)
    lower = np.nanmin(height, axis=-1)  # (N, T)
    standing = np.nanpercentile(lower, 5, axis=-1)[:, None, None]  # (N, 1, 1)
    stance = (height == lower[..., None]) & (height < standing + STANCE_BAND)
    step = np.diff(ankles, axis=1)
    along = np.linalg.norm(step - (step @ normal)[..., None] * normal, axis=-1)  # (N, T-1, 2)
    both = stance[:, 1:] & stance[:, :-1] & np.isfinite(along)
    return along[both]


def person_plausibility(blocks: Iterable[np.ndarray], views_seen: np.ndarray, floor: Floor | None) -> dict:
    """Figures and flags of one person: their hypotheses as consecutive blocks of frames ``(N, t, 17, 3)`` (NaN
    where absent), ``views_seen`` ``(T,)`` the number of cameras seeing the person per frame."""
    under, counted, slides, spreads, lows = 0, 0, [], [], []
    for block in blocks:
        block = np.asarray(block, dtype=np.float64)
        block = block[:, np.isfinite(block).all(axis=(0, -1, -2))]
        if block.shape[1] == 0:
            continue
        if floor is not None:
            low = lowest_ankle(block, floor)
            under, counted = under + int((low < -UNDER_FLOOR).sum()), counted + low.size
            lows.append(np.median(low, axis=0))
        slides.append(stance_slides(block, floor))
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
    if report["several_views_share"] < 0.5:
        flags.append("one view")
    return {**report, "flags": flags}


def plausibility(hypotheses, keypoints: np.ndarray, floor: Floor | None, chunk: int = CHUNK) -> list[dict]:
    """:func:`person_plausibility` of every person: hypotheses ``(P, N, T, 17, 3)`` (an array, or anything indexed
    like one, read ``chunk`` frames at a time), keypoints ``(C, T, P, 17, 3)`` (x, y, confidence) on the same
    frames."""
    seen = ((np.nan_to_num(keypoints[..., 2]) > 0).sum(axis=-1) >= 4).sum(axis=0)  # (T, P) cameras seeing 4+ joints
    P, T = hypotheses.shape[0], hypotheses.shape[2]
    reports = []
    for p in range(P):
        blocks = (hypotheses[p, :, start : start + chunk] for start in range(0, T, chunk))
        reports.append(person_plausibility(blocks, seen[:, p], floor))
    return reports


def plausibility_lines(reports: list[dict], track_ids: list | np.ndarray) -> list[str]:
    """One console line per person with a flag: what is implausible and the figure behind it."""
    lines = []
    for track, report in zip(track_ids, reports):
        if not report["flags"]:
            continue
        details = []
        if "under floor" in report["flags"]:
            details.append(f"{report['under_floor_share']:.0%} of hypothesis-frames under the floor")
        if "sliding" in report["flags"]:
            details.append(f"stance feet slide {100 * report['stance_slide_median_m']:.1f} cm per frame")
        if "spread" in report["flags"]:
            details.append(f"hypotheses spread over {report['pelvis_spread_m']:.1f} m")
        if "one view" in report["flags"]:
            details.append("seen by one camera: depth and size from the prior")
        lines.append(f"person {track}: flagged ({', '.join(report['flags'])}): {'; '.join(details)}")
    return lines
