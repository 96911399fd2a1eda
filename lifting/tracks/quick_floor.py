"""The floor under a one-camera take, estimated before its lift: a quick ungrounded lift of the persons present
longest, and the plane under their standing ankles."""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import replace

import numpy as np

from platypose.lifting.calibration.pose_above_floor import pitched
from platypose.lifting.camera import Camera
from platypose.lifting.floor import Floor, floor_under
from platypose.lifting.job_log import JobLog
from platypose.lifting.prior.model import PriorBundle
from platypose.lifting.settings import SamplerConfig, WindowSettings
from platypose.lifting.tracks.persons import lift_persons

FLOOR_PASS_SAMPLES = 10  # hypotheses of the quick lift a one-camera floor is estimated under
FLOOR_PASS_PERSONS = 4  # persons (present longest) whose standing ankles it is estimated from
QUICK_LIFT = "the floor's quick lift"  # what progress calls the quick lift's windows


def quick_floor(
    prior: PriorBundle,
    keypoints: np.ndarray,
    times: np.ndarray,
    absent: np.ndarray,
    cameras: Sequence[Camera],
    roots: Sequence[np.ndarray | None],
    sampler: SamplerConfig,
    windows: WindowSettings,
    fps: float,
    log: JobLog,
    progress: Callable[[list[int] | str, int, int], None] | None = None,
    lifter: Callable = lift_persons,
    level_known: bool = False,
) -> tuple[Floor | None, dict | None]:
    """The floor under a one-camera take (keypoints (1, T, P, 17, 3), persons ``absent`` (P, T)) and its ``meta``
    entry, estimated (:func:`platypose.lifting.floor.floor_under`) under the median motions of a quick lift
    without a floor: ``FLOOR_PASS_SAMPLES`` hypotheses of the ``FLOOR_PASS_PERSONS`` persons present longest;
    None, None (logged) when too few standing ankles are found. ``progress(QUICK_LIFT, done, total)`` counts its
    windows; ``lifter`` lifts them (as :func:`lift_persons`). ``level_known``: the camera's roll and pitch are the
    scene's, only the floor's height is estimated."""
    if len(cameras) != 1:
        return None, None
    began = time.perf_counter()
    persons = np.argsort(absent.sum(axis=1), kind="stable")[:FLOOR_PASS_PERSONS]
    quick = replace(sampler, samples=min(sampler.samples, FLOOR_PASS_SAMPLES), floor=None)
    P, T = len(persons), len(times)
    hypotheses, energy = np.empty((P, quick.samples, T, 17, 3), np.float32), np.empty((P, quick.samples, T), np.float32)
    median = np.empty((P, T, 17, 3), np.float32)
    kept = keypoints[:, :, persons]
    lifter(
        prior,
        kept,
        times,
        cameras,
        [roots[p] for p in persons],
        absent[persons],
        quick,
        windows,
        hypotheses,
        median,
        energy,
        None if progress is None else (lambda group, done, total: progress(QUICK_LIFT, done, total)),
    )
    floor, meta = floor_under(median, cameras[0], fps, kept[0], level_known)
    seconds = time.perf_counter() - began
    if floor is None:
        log(f"floor: too few standing ankles to estimate it under a quick lift ({seconds:.1f} s); lifting without one")
    else:
        log(
            f"floor estimated under a quick lift of {quick.samples} hypotheses ({seconds:.1f} s): camera "
            f"{meta['camera_height_m']:.2f} m above it, {pitched(meta['camera_pitch_deg'])} "
            f"{'(the scene) ' if level_known else ''}"
            f"({meta['stance_points']} standing ankles); --floor z=H or a calibration sets it instead"
        )
    return floor, meta
