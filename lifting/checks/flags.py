"""The words that say what is wrong with a person's lift: one sentence per person, the same wherever it is shown.

A person's plausibility report (:mod:`lifting.checks.plausibility`) carries ``flags`` (names) and the figures behind them;
:func:`flag_text` turns them into one sentence, which the lift stores in the report as ``flag_text`` so the console,
``log.txt``, ``summary.json``, the report picture and the rerun recording all say the same. Only what is wrong is
flagged: under the floor, sliding, a spread over ``SPREAD``, limb bones outside human lengths, joints outside human
range, knee or elbow flexion changing faster than a body turns it (``hinge jumps``, with the frames), a body after a gap
not the one before it (``size after gap``, :mod:`lifting.checks.gap_size`), an OpenSim IK that pins a hinge at its limit or leaves large marker errors (added by ``--formats mot``,
:func:`exporters.mot.flag_ik`). Being seen by one camera is not wrong (depth and size then come from the prior): it is the report's
``one_view`` property. Where a person stands off the floor (a roof, a platform) is said too, flagged or not
(:func:`support_text`).
"""

from __future__ import annotations

import numpy as np

from platypose.lifting.checks.body import HINGE_SPEED_DEG_S
from platypose.lifting.checks.thresholds import ON_FLOOR, SPREAD, UNDER_FLOOR


def _frames(frames: list[int], shown: int = 8) -> str:
    """Frame numbers as ``"3, 17, 40"``, the first ``shown`` and how many more."""
    more = f" and {len(frames) - shown} more" if len(frames) > shown else ""
    return ", ".join(map(str, frames[:shown])) + more


def _detail(flag: str, report: dict) -> str:
    """The figure behind one flag of ``report``."""
    if flag == "under floor":
        return f"{report['under_floor_share']:.0%} of hypothesis-frames more than {100 * UNDER_FLOOR:.0f} cm under it"
    if flag == "sliding":
        return f"standing feet slide {100 * report['stance_slide_median_m']:.1f} cm per frame"
    if flag == "spread":
        return f"hypotheses {report['pelvis_spread_m']:.1f} m apart (over {SPREAD:g} m)"
    if flag == "bone lengths":
        return ", ".join(
            f"{name} {entry['length_m']:.2f} m (human {entry['range_m'][0]:.2f}-{entry['range_m'][1]:.2f})"
            for name, entry in report["bone_lengths_out"].items()
        )
    if flag == "joint angles":
        return ", ".join(
            f"{name} {entry['max_deg']:.0f} degrees (human at most {entry['limit_deg']:.0f}) in {entry['share']:.0%} "
            "of frames"
            for name, entry in report["angles_out"].items()
        )
    if flag == "behind camera":
        return (
            f"the pelvis lies behind a camera that sees them in {report['behind_camera_share']:.0%} of frames, "
            f"median depth {report['pelvis_depth_median_m']:.1f} m: impossible geometry (keypoints upside down, "
            "or a wrong calibration?)"
        )

    if flag == "hinge jumps":
        return ", ".join(
            f"{name} {entry['max_deg_per_s']} degrees/s (over {HINGE_SPEED_DEG_S:.0f}) in frames {_frames(entry['frames'])}"
            for name, entry in report["hinge_jumps"].items()
        )
    if flag == "size after gap":
        gap = report["size_after_gap"]
        return (
            f"after the gap in frames {gap['first_frame']}-{gap['last_frame']} the keypoints give a body {gap['ratio']:g} "
            "times the one before it (another person, or the floor or depth off): one body is a compromise there"
        )
    if flag == "opensim ik":
        return "; ".join(report["opensim_ik_warnings"])
    raise ValueError(f"unknown flag {flag!r}")


def flag_text(report: dict) -> str:
    """One sentence for the flags of a person's ``report`` (empty when nothing is wrong):
    ``"under floor (12% of hypothesis-frames more than 3 cm under it); spread (...)"``."""
    return "; ".join(f"{flag} ({_detail(flag, report)})" for flag in report.get("flags", []))


def support_text(levels: list[dict]) -> str:
    """Where a person stands off the floor, from their support ``levels``
    (:func:`lifting.checks.plausibility.support_levels`)."""
    parts = [
        f"{abs(level['height_m']):.2f} m {'above' if level['height_m'] > 0 else 'below'} the floor in frames "
        f"{level['first_frame']}-{level['last_frame']}"
        for level in levels
    ]
    return "stands " + ", ".join(parts)


def person_lines(reports: list[dict], track_ids: list | np.ndarray) -> list[str]:
    """One line per person that is flagged (``person 1: flagged: <flag_text>``) or stands off the floor
    (``person 0: stands 1.92 m above the floor in frames 0-122``); nothing for a person on the floor with no flag."""
    lines = []
    for track, report in zip(track_ids, reports):
        raised = [level for level in report.get("support", []) if abs(level["height_m"]) > ON_FLOOR]
        text = report.get("flag_text") or flag_text(report)
        parts = ([f"flagged: {text}"] if text else []) + ([support_text(raised)] if raised else [])
        if parts:
            lines.append(f"person {track}: " + "; ".join(parts))
    return lines
