"""The floor under a one-camera take, estimated before its lift: a quick ungrounded lift of the persons present
longest, and the plane under their standing ankles. A long take is read in a few stretches spread over it
(:func:`platypose.lifting.tracks.quick_floor.floor_frames`), so the quick lift costs no more for a match than for
two minutes, and it is the same whether the take's lift is split into pieces or not."""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import replace

import numpy as np

from platypose.lifting.calibration.pose_above_floor import pitched
from platypose.lifting.floor import Floor, floor_under
from platypose.lifting.job_log import JobLog
from platypose.lifting.prior.model import PriorBundle
from platypose.lifting.take import Take
from platypose.lifting.tracks.persons import lift_persons

FLOOR_PASS_SAMPLES = 10  # hypotheses of the quick lift a one-camera floor is estimated under
FLOOR_PASS_PERSONS = 4  # persons (present longest) whose standing ankles it is estimated from
QUICK_LIFT = "the floor's quick lift"  # what progress calls the quick lift's windows
FLOOR_PASS_SECONDS = 120.0  # seconds of a take the quick lift reads at most (the 60 s clip: 552 standing ankles)
FLOOR_PASS_STRETCHES = 6  # stretches they are read in, spread evenly over a longer take


def floor_frames(
    times: np.ndarray, seconds: float = FLOOR_PASS_SECONDS, stretches: int = FLOOR_PASS_STRETCHES
) -> np.ndarray:
    """Indices of the frames of a take on ``times`` (T,) that its floor's quick lift reads: every frame of a take
    up to ``seconds`` long; of a longer one, ``stretches`` stretches of ``seconds / stretches`` each, centred at
    evenly spaced times over it (the camera stands still: its floor is everywhere the same, and people walk
    about)."""
    times = np.asarray(times, dtype=np.float64)
    start, span = times[0], times[-1] - times[0]
    if span <= seconds:
        return np.arange(len(times))
    half = seconds / stretches / 2
    centres = start + (np.arange(stretches) + 0.5) * span / stretches
    keep = (np.abs(times[:, None] - centres[None]) <= half).any(axis=1)
    return np.flatnonzero(keep)


def quick_floor(
    prior: PriorBundle,
    take: Take,
    *,
    log: JobLog,
    progress: Callable[[list[int] | str, int, int], None] | None = None,
    height_only: bool = False,
) -> Floor | None:
    """The floor under a one-camera ``take`` (keypoints (1, T, P, 17, 3)) with what its estimate found (its ``meta``
    entry: :func:`platypose.lifting.floor.floor_under`), estimated under the median motions of a quick lift
    without a floor: ``FLOOR_PASS_SAMPLES`` hypotheses of the ``FLOOR_PASS_PERSONS`` persons present longest;
    None (logged) when too few standing ankles are found. A take longer than ``FLOOR_PASS_SECONDS`` is read in
    the stretches of :func:`platypose.lifting.tracks.quick_floor.floor_frames`. ``progress(QUICK_LIFT, done,
    total)`` counts its windows.
    ``height_only``: the camera's roll and pitch are the scene's, only the floor's height is estimated."""
    if len(take.cameras) != 1:
        return None
    began = time.perf_counter()
    fps = take.frame_rate(prior.fps)
    persons = np.argsort(take.absent.sum(axis=1), kind="stable")[:FLOOR_PASS_PERSONS]
    sampler = replace(take.sampler, samples=min(take.sampler.samples, FLOOR_PASS_SAMPLES), floor=None)
    chosen, frames = take.persons(persons), floor_frames(take.times, FLOOR_PASS_SECONDS, FLOOR_PASS_STRETCHES)
    quick = Take.on_clock(
        chosen.keypoints[:, frames],
        chosen.times[frames],
        chosen.track_ids,
        chosen.cameras,
        [None if root is None else root[frames] for root in chosen.roots],
        sampler=sampler,
        windows=take.windows,
    )
    P, T = len(persons), len(quick.times)
    hypotheses, energy = (
        np.empty((P, sampler.samples, T, 17, 3), np.float32),
        np.empty((P, sampler.samples, T), np.float32),
    )
    median = np.empty((P, T, 17, 3), np.float32)
    lift_persons(
        prior=prior,
        take=quick,
        hypotheses=hypotheses,
        median=median,
        energy=energy,
        progress=None if progress is None else (lambda group, done, total: progress(QUICK_LIFT, done, total)),
    )
    floor = floor_under(median, take.cameras[0], fps, quick.keypoints[0], height_only)
    seconds = time.perf_counter() - began
    if floor is None:
        log(f"floor: too few standing ankles to estimate it under a quick lift ({seconds:.1f} s); lifting without one")
    else:
        found = floor.found
        log(
            f"floor estimated under a quick lift of {sampler.samples} hypotheses{_read(take.times, frames)} "
            f"({seconds:.1f} s): camera "
            f"{found['camera_height_m']:.2f} m above it, {pitched(found['camera_pitch_deg'])} "
            f"{'(the scene) ' if height_only else ''}"
            f"({found['stance_points']} standing ankles); --floor z=H or a calibration sets it instead"
        )
    return floor


def _read(times: np.ndarray, frames: np.ndarray) -> str:
    """What of the take on ``times`` the quick lift read in ``frames``, for the log ("" for all of it)."""
    if len(frames) == len(times):
        return ""
    return f" over {FLOOR_PASS_SECONDS:g} s of the take in {FLOOR_PASS_STRETCHES} stretches"
