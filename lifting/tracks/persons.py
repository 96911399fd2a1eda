"""Lifting one take: every person's root path, their hypotheses written frame chunk by chunk.

A take is 2D keypoints ``(C, T, P, 17, 3)`` of P persons seen by C calibrated cameras
on one clock ``(T,)``. :func:`root_paths` decides per person whether the pelvis path is
known (given, or triangulated from two or more views) or solved per hypothesis;
:func:`lift_persons` lifts the two groups of a :class:`~platypose.lifting.take.Take` apart and writes hypotheses,
their median and their energy into arrays the caller owns (numpy arrays, memory maps, ...) as
lifting hands frames out, so memory stays bounded. No file is read or written.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from platypose.lifting.camera import Camera
from platypose.lifting.errors import InputError
from platypose.lifting.prior.model import PriorBundle
from platypose.lifting.settings import ROOT_MODES
from platypose.lifting.take import Take
from platypose.lifting.tracks.roots import fill_gaps, triangulated_root
from platypose.lifting.tracks.stream import lift_stream

MIN_ROOT_COVERAGE = 0.5  # share of frames with a triangulated pelvis needed to use the path (gaps interpolated)


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
    take: Take,
    hypotheses,
    median,
    energy,
    progress: Callable[[list[int], int, int], None] | None = None,
) -> None:
    """Lift ``take`` (keypoints (C, T, P, 17, 3)) into ``hypotheses`` (P, N, T, 17, 3), ``median`` (P, T, 17, 3) and
    ``energy`` (P, N, T) (anything indexable like numpy arrays), NaN where the take's persons are ``absent`` (P, T).

    Persons with a known root (``take.roots[p]`` (T, 3)) and the others are lifted apart, each
    group in one batch, over the frames where they are present (the take's ``absent``, computed once);
    frames are written as lifting hands them out. ``progress(group, done, total)`` counts each group's windows.
    """
    P = take.absent.shape[0]
    known = [p for p in range(P) if take.roots[p] is not None]
    unknown = [p for p in range(P) if take.roots[p] is None]
    for group, has_root in ((known, True), (unknown, False)):
        if not group:
            continue
        root = np.stack([take.roots[p] for p in group]) if has_root else None
        report = None if progress is None else (lambda done, total, g=group: progress(g, done, total))
        chunks = lift_stream(
            prior,
            take.cameras,
            take.keypoints[:, :, group],
            take.times,
            take.sampler,
            take.windows,
            root_trajectory=root,
            progress=report,
            present=~take.absent[group],
            identities=[int(take.track_ids[p]) for p in group],
        )
        for chunk in chunks:
            t = slice(chunk.start, chunk.start + chunk.hypotheses.shape[2])
            gone = take.absent[group, t][:, None]  # (G, 1, t)
            chunk.hypotheses[np.broadcast_to(gone, chunk.hypotheses.shape[:3])] = np.nan
            chunk.energy[np.broadcast_to(gone, chunk.energy.shape)] = np.nan
            hypotheses[group, :, t] = chunk.hypotheses
            energy[group, :, t] = chunk.energy
            median[group, t] = np.median(chunk.hypotheses, axis=1)
