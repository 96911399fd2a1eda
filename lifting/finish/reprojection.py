"""Finishing step 3: how far the median motion lies from each view's keypoints, per view, logged with a warning for
a view (or a calibration) that does not fit (:func:`report_reprojection`)."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from platypose.lifting.camera import Camera
from platypose.lifting.job_log import JobLog
from platypose.lifting.triangulation import view_median_errors

REPROJECTION_WARNING_SHARE = 0.02  # of the image width: a view the median motion misses by more is suspect
WELL_SEEN_SHARE = 0.25  # a view is judged by the persons it sees in at least this share of their frames


def well_seen(keypoints: np.ndarray) -> np.ndarray:
    """(C, P): whether view c sees person p in at least ``WELL_SEEN_SHARE`` of the frames where it sees anyone
    (the person a view sees most always counts), from ``keypoints`` (C, T, P, 17, 3)."""
    seen = keypoints[..., 2].max(axis=-1) > 0  # (C, T, P)
    frames = np.maximum(seen.any(axis=2).sum(axis=1, keepdims=True), 1)  # (C, 1)
    share = seen.sum(axis=1) / frames  # (C, P)
    return (share >= WELL_SEEN_SHARE) | (share == share.max(axis=1, keepdims=True))


def reprojection_report(
    median: np.ndarray, keypoints: np.ndarray, cameras: Sequence[Camera]
) -> tuple[dict[str, float], list[str]]:
    """Per view, the median pixel distance between the median motion ``(P, T, 17, 3)`` and the view's keypoints
    ``(C, T, P, 17, 3)`` (the largest over the persons the view sees well: :func:`well_seen`), and a warning for each view above
    ``REPROJECTION_WARNING_SHARE`` of its image width; one warning instead when every view that sees someone is
    above it (the calibration as a whole does not fit the videos: swapped, or another take's).

    With one view guidance fits the keypoints exactly and nothing is reported (empty dict). With several, a
    view far off the others usually has a wrong calibration (or a detector that lost the person there).
    """
    if len(cameras) < 2:
        return {}, []
    per_person = [view_median_errors(median[p], keypoints[:, :, p], cameras) for p in range(keypoints.shape[2])]
    errors = np.full(len(cameras), np.nan)
    if per_person:
        stacked = np.stack(per_person, axis=1)  # (C, P)
        judged = np.where(well_seen(keypoints) & np.isfinite(stacked), stacked, -np.inf).max(axis=1)
        errors = np.where(np.isfinite(judged), judged, np.nan)  # NaN: a view that sees nobody
    report = {cam.name: round(float(e), 2) for cam, e in zip(cameras, errors)}
    off = [
        (cam, value) for cam, value in zip(cameras, report.values()) if value > REPROJECTION_WARNING_SHARE * cam.width
    ]
    seeing = [value for value in report.values() if np.isfinite(value)]  # views that see someone
    if len(off) >= 2 and len(off) == len(seeing):  # no view fits: the calibration, not a view, is wrong
        low, high = min(v for _, v in off), max(v for _, v in off)
        shares = [value / cam.width for cam, value in off]
        share = (
            f"{min(shares):.0%}"
            if f"{min(shares):.0%}" == f"{max(shares):.0%}"
            else f"{min(shares):.0%}-{max(shares):.0%}"
        )
        return report, [
            f"views {', '.join(cam.name for cam, _ in off)} (no view fits): the median motion lies {low:.1f}-{high:.1f} "
            f"px (median) from their keypoints, {share} of the image "
            "width: the calibration does not fit these videos (videos or camera names swapped, or another take's "
            "calibration?); check it with platypose calib check"
        ]
    return report, [
        f"view {cam.name}: the median motion lies {value:.1f} px (median) from its keypoints, "
        f"{value / cam.width:.0%} of the image width; check its calibration and its detections"
        for cam, value in off
    ]


def report_reprojection(median, keypoints: np.ndarray, cameras: Sequence[Camera], log: JobLog) -> dict[str, float]:
    """:func:`reprojection_report` logged: one line of per-view pixels, then its warnings."""
    report, warnings = reprojection_report(median, keypoints, cameras)
    if report:
        log(
            "median motion against the keypoints (median px per view): "
            + ", ".join(f"{name} {value:.1f}" for name, value in report.items())
        )
    for warning in warnings:
        log.warning(warning)
    return report
