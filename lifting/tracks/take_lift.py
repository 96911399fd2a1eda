"""A take lifted and finished: the one path from a :class:`~platypose.lifting.take.Take` to its finished arrays.

:func:`platypose.pipeline.lift_take` (every ``lift``) and ``eval --gap`` (:mod:`platypose.lifting.offline.evaluation`)
both run it, so what the evaluation scores is what a lift of a take with a gap exports: the persons sampled through
the take's windows and their anchors (placement across gaps included, :func:`lift_persons`), then finished
(:func:`platypose.lifting.finish.steps.finish_take`: steady depth, bodies, plausibility).
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass, replace

import numpy as np

from platypose.lifting.finish.steps import FinishedTake, finish_take
from platypose.lifting.floor import Floor
from platypose.lifting.job_log import JobLog
from platypose.lifting.prior.model import PriorBundle
from platypose.lifting.take import Take
from platypose.lifting.tracks.persons import lift_persons


def numpy_arrays(shape: tuple[int, ...], name: str) -> np.ndarray:
    """An in-memory float32 array for one of the result's long arrays (``name``: hypotheses, median, energy)."""
    return np.empty(shape, np.float32)


@dataclass(frozen=True)
class LiftedTake:
    """A take's ``hypotheses`` (P, N, T, 17, 3), ``median`` (P, T, 17, 3) and ``energy`` (P, N, T), finished, at
    ``fps``; what finishing left besides them (``finished``)."""

    hypotheses: object
    median: object
    energy: object
    fps: float
    finished: FinishedTake


def lift_and_finish(
    prior: PriorBundle,
    take: Take,
    *,
    floor: Floor | None,
    log: JobLog,
    arrays: Callable[[tuple[int, ...], str], object] = numpy_arrays,
    progress: Callable | None = None,
    lifter: Callable = lift_persons,
) -> LiftedTake:
    """Lift ``take``'s persons grounded on ``floor`` (its plane replaces ``take.sampler.floor``; None: as the take
    says) into arrays made by ``arrays(shape, name)``, with ``lifter`` (:func:`lift_persons`, or the same spread over
    pieces) reporting ``progress(group, done, total)``, then finish them on ``floor``; each step logged."""
    fps = take.frame_rate(prior.fps)
    if floor is not None:
        take = replace(take, sampler=replace(take.sampler, floor=floor.plane))
        log(f"floor ({floor.source}): {' '.join(f'{v:g}' for v in floor.plane)} (n . x + d = 0), grounding on")
    started = time.perf_counter()
    (P, T), N = take.absent.shape, take.sampler.samples
    hypotheses = arrays((P, N, T, 17, 3), "hypotheses")
    median = arrays((P, T, 17, 3), "median")
    energy = arrays((P, N, T), "energy")
    lifter(prior=prior, take=take, hypotheses=hypotheses, median=median, energy=energy, progress=progress)
    log(f"lifted {N} hypotheses in {time.perf_counter() - started:.1f} s")
    finished = finish_take(take, hypotheses=hypotheses, median=median, fps=fps, floor=floor, log=log)
    return LiftedTake(hypotheses, median, energy, fps, finished)
