"""Lifting one take: every person's root path, their hypotheses written frame chunk by chunk, the per-view report.

A take is 2D keypoints ``(C, T, P, 17, 3)`` of P persons seen by C calibrated cameras
on one clock ``(T,)``. :func:`root_paths` decides per person whether the pelvis path is
known (given, or triangulated from two or more views) or solved per hypothesis;
:func:`lift_persons` lifts the two groups apart and writes hypotheses, their median
and their energy into arrays the caller owns (numpy arrays, memory maps, ...) as
lifting hands frames out, so memory stays bounded; :func:`reprojection_report` says
how far the median motion lies from each view's keypoints. No file is read or written.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from platypose.lifting.camera import Camera
from platypose.lifting.errors import InputError
from platypose.lifting.prior.model import PriorBundle
from platypose.lifting.settings import ROOT_MODES, SamplerConfig, WindowSettings
from platypose.lifting.tracks.roots import fill_gaps, triangulated_root
from platypose.lifting.tracks.stream import lift_stream
from platypose.lifting.triangulation import view_median_errors

MIN_ROOT_COVERAGE = 0.5  # share of frames with a triangulated pelvis needed to use the path (gaps interpolated)
REPROJECTION_WARNING_SHARE = 0.02  # of the image width: a view the median motion misses by more is suspect
WELL_SEEN_SHARE = 0.25  # a view is judged by the persons it sees in at least this share of their frames


def check_root_mode(root: str) -> None:
    """InputError unless ``root`` is one of ``ROOT_MODES``."""
    if root not in ROOT_MODES:
        raise InputError(f"root must be one of {', '.join(ROOT_MODES)}, got {root!r}", option="root")


def root_paths(
    keypoints: np.ndarray,
    times: np.ndarray,
    cameras: Sequence[Camera],
    root: str = "auto",
    given: Sequence[np.ndarray] | None = None,
    say: Callable[[str], None] = lambda message: None,
) -> list[np.ndarray | None]:
    """Per person of ``keypoints`` (C, T, P, 17, 3): a known root path (T, 3), or None to solve it per hypothesis.

    ``given`` (one path per person) wins; else ``root`` "solve" (or "auto" with one camera)
    solves every root, "triangulate" (or "auto" with two or more) triangulates the pelvis
    and uses the path where at least ``MIN_ROOT_COVERAGE`` of the frames have it.
    ``say`` receives one line per decision.
    """
    P = keypoints.shape[2]
    check_root_mode(root)
    if given is not None:
        return list(given)
    if root == "solve" or (root == "auto" and len(cameras) < 2):
        say("root: solved per hypothesis from the rays of every camera")
        return [None] * P
    if len(cameras) < 2:
        raise InputError(f"root triangulate needs two or more calibrated views, got {len(cameras)}", option="root")
    roots = triangulated_root(keypoints, cameras)
    paths: list[np.ndarray | None] = []
    for p in range(P):
        covered = np.isfinite(roots[p]).all(-1).mean()
        usable = covered >= MIN_ROOT_COVERAGE
        say(
            f"root of person {p}: pelvis triangulated in {covered:.0%} of frames; "
            + ("gaps interpolated" if usable else "too few, solved per hypothesis instead")
        )
        paths.append(fill_gaps(roots[p], times) if usable else None)
    return paths


def root_kinds(roots: Sequence[np.ndarray | None], given: bool) -> list[str]:
    """What each person's root path is, for a result's meta: "given", "triangulated" or "solved"."""
    return ["given" if given else ("solved" if r is None else "triangulated") for r in roots]


def lift_persons(
    prior: PriorBundle,
    keypoints: np.ndarray,
    times: np.ndarray,
    cameras: Sequence[Camera],
    roots: Sequence[np.ndarray | None],
    absent: np.ndarray,
    config: SamplerConfig,
    windows: WindowSettings,
    hypotheses,
    median,
    energy,
    progress: Callable[[list[int], int, int], None] | None = None,
) -> None:
    """Lift ``keypoints`` (C, T, P, 17, 3) into ``hypotheses`` (P, N, T, 17, 3), ``median`` (P, T, 17, 3) and
    ``energy`` (P, N, T) (anything indexable like numpy arrays), NaN where ``absent`` (P, T).

    Persons with a known root (``roots[p]`` (T, 3)) and the others are lifted apart, each
    group in one batch; frames are written as lifting hands them out.
    ``progress(group, done, total)`` counts each group's windows.
    """
    P = absent.shape[0]
    known = [p for p in range(P) if roots[p] is not None]
    unknown = [p for p in range(P) if roots[p] is None]
    for group, has_root in ((known, True), (unknown, False)):
        if not group:
            continue
        root = np.stack([roots[p] for p in group]) if has_root else None
        report = None if progress is None else (lambda done, total, g=group: progress(g, done, total))
        for chunk in lift_stream(prior, cameras, keypoints[:, :, group], times, config, windows, root, report):
            t = slice(chunk.start, chunk.start + chunk.hypotheses.shape[2])
            gone = absent[group, t][:, None]  # (G, 1, t)
            chunk.hypotheses[np.broadcast_to(gone, chunk.hypotheses.shape[:3])] = np.nan
            chunk.energy[np.broadcast_to(gone, chunk.energy.shape)] = np.nan
            hypotheses[group, :, t] = chunk.hypotheses
            energy[group, :, t] = chunk.energy
            median[group, t] = np.median(chunk.hypotheses, axis=1)


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
