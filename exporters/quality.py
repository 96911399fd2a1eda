"""How far to trust each person of a lift: the hypotheses' spread, reasons to check a person, a Markdown summary.

Shown by the rerun recording (``quality``, :mod:`platypose.exporters.rrd`); read from the result and its meta only.
"""

from __future__ import annotations

import numpy as np

from platypose.exporters.frames import frame_chunks
from platypose.exporters.result import LiftResult

SPREAD_FLAG_M = 0.15  # a person whose mean joint spread exceeds this is flagged
STRETCH_FLAG_M = 0.10  # ... or whose BVH had to absorb a bone stretching by more than this


def per_joint_spread(hypotheses: np.ndarray, median: np.ndarray) -> np.ndarray:
    """RMS distance of hypotheses (N, T, 17, 3) to the median (T, 17, 3) per frame and joint, (T, 17)."""
    return np.sqrt(np.mean(np.sum((hypotheses - median[None]) ** 2, axis=-1), axis=0))


def person_report(result: LiftResult, p: int) -> dict | None:
    """Person ``p``'s entry of ``meta["plausibility"]`` (one dict per person, :mod:`lifting.plausibility`), if any."""
    reports = result.meta.get("plausibility") or []
    return reports[p] if p < len(reports) and isinstance(reports[p], dict) else None


def quality_flags(result: LiftResult, p: int) -> list[str]:
    """Reasons to check person ``p`` (empty when none): a large spread, a stretching skeleton, few frames, and the
    lift's own plausibility flags (under the floor, sliding, one view)."""
    flags = [f"plausibility: {flag}" for flag in (person_report(result, p) or {}).get("flags", [])]
    present = result.present()[p]
    track = f"p{result.track_ids[p]}"
    spread = mean_spread(result, p)
    if spread > SPREAD_FLAG_M:
        flags.append(f"hypotheses spread {1000 * spread:.0f} mm on average (over {1000 * SPREAD_FLAG_M:.0f})")
    fit = result.meta.get("bvh_fit_error", {}).get(track, {}).get("median", {})
    if fit.get("stretch_m", 0.0) > STRETCH_FLAG_M:
        flags.append(f"bones stretch by up to {1000 * fit['stretch_m']:.0f} mm (not a rigid body)")
    if present.mean() < 0.5:
        flags.append(f"present in {present.sum()} of {len(present)} frames")
    return flags


def mean_spread(result: LiftResult, p: int) -> float:
    """Mean over present frames and joints of the hypotheses' RMS distance to the median, metres."""
    total, count = 0.0, 0
    present = result.present()[p]
    for t in frame_chunks(result.num_frames):
        on = np.flatnonzero(present[t])
        if len(on):
            hyp = np.asarray(result.hypotheses[p, :, t], np.float64)[:, on]
            spread = per_joint_spread(hyp, np.asarray(result.median[p, t], np.float64)[on])
            total, count = total + spread.sum(), count + spread.size
    return total / max(count, 1)


def quality_text(result: LiftResult, flags: dict[int, list[str]]) -> str:
    """Markdown: per person frames, spread, BVH fit, flags and ``meta["plausibility"]`` entry; the lift's warnings."""
    lines = ["# Quality", ""]
    present = result.present()
    for p, track in enumerate(result.track_ids):
        fit = result.meta.get("bvh_fit_error", {}).get(f"p{track}", {}).get("median")
        line = f"- **p{track}**: present in {present[p].sum()} / {result.num_frames} frames"
        if present[p].any():
            line += f", mean joint spread {1000 * mean_spread(result, p):.0f} mm"
        if fit:
            line += f", BVH fit {1000 * fit['mean_m']:.0f} mm mean / {1000 * fit['max_m']:.0f} mm max"
        lines.append(line)
        lines += [f"  - check: {f}" for f in flags.get(p, [])]
        report = person_report(result, p)
        if report is not None:
            lines.append(f"  - plausibility: {', '.join(report.get('flags', [])) or 'no flags'}")
    warnings = result.meta.get("warnings") or []
    if warnings:
        lines += ["", "## Warnings", ""] + [f"- {w}" for w in warnings]
    return "\n".join(lines) + "\n"
