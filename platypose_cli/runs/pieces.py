"""``platypose lift --split-seconds S``: the piece tasks of one input, their results cached as files under
``OUT/<name>/.pieces/``.

Two kinds of piece task: :func:`detect_piece` detects the frames of one stretch of a video, :func:`lift_piece` lifts
the persons of one stretch of a take's 2D. Each writes its result atomically into the piece folder under a name
that digests everything it depends on, so a resumed run finds the pieces that finished and redoes only the others;
the folder goes when the input's files are written. The pools that run them are :mod:`platypose.cli.runs.pools`;
:mod:`platypose.cli.runs.split` plans the pieces and joins their results.
"""

from __future__ import annotations

import os
import shutil
import stat
import time
from collections.abc import Callable
from contextlib import suppress
from pathlib import Path

import numpy as np

from platypose.cli.runs.models import cached_detector, loaded_prior
from platypose.lifting.errors import InputError
from platypose.lifting.files.reads import file_kind

PIECES = ".pieces"  # in OUT/<name>/: piece results of a split lift, until its files are written
Task = tuple[Callable, tuple]  # a module-level function and its (picklable) arguments


def piece_folder(out: Path, name: str) -> Path:
    """Where the pieces of job ``name`` are cached."""
    return out / name / PIECES


def make_piece_folder(folder: Path) -> None:
    """Create the piece folder ``folder`` if missing; InputError naming it when something else is in its place (a
    symbolic link would lead the pieces out of ``--out``, a file would fail every run), as a lock file is refused."""
    folder.parent.mkdir(parents=True, exist_ok=True)
    with suppress(FileExistsError):
        folder.mkdir()
    mode = os.lstat(folder).st_mode
    if not stat.S_ISDIR(mode):
        kind = "a regular file" if stat.S_ISREG(mode) else file_kind(mode)
        raise InputError(f"{folder}: is {kind}, not the folder of pieces platypose made; remove it")


def remove_pieces(out: Path, name: str) -> None:
    """Remove job ``name``'s piece cache (its files are written)."""
    shutil.rmtree(piece_folder(out, name), ignore_errors=True)


def detect_piece(video: str, detect, start: int, stamp: int | None, count: int | None, path: str, key: str) -> float:
    """Detect frames ``start ..`` (``count`` of them, None: to the end) of ``video`` with the detector of ``detect``
    (DetectOptions), every ``detect.stride``-th by index; save them (:class:`~platypose.detectors.cache.DetectionCache` layout) at ``path``.
    The seconds it took."""
    from platypose.detectors.cache import DetectionCache
    from platypose.detectors.sources.video_range import iter_frame_range

    model = cached_detector(detect)
    started = time.perf_counter()
    detections, indices = [], []
    for index, frame in iter_frame_range(video, start, stamp, count, detect.stride):
        detections.append(np.asarray(model(frame), dtype=np.float32))
        indices.append(index)
    target = Path(path)
    DetectionCache(target.parent, target.name.removesuffix(".detections.npz")).save(
        key, detections, np.asarray(indices, dtype=np.int64)
    )
    return time.perf_counter() - started


def lift_piece(prior_settings, take, path: str) -> float:
    """Lift one stretch of a take (:func:`platypose.lifting.tracks.persons.lift_persons` on ``take``, a Take) with the
    prior of ``prior_settings``; save its hypotheses and energy (float32, NaN where absent) atomically at ``path``.
    The seconds it took (the prior loaded, once per process)."""
    from platypose.lifting.files.atomic import atomic_open
    from platypose.lifting.tracks.persons import lift_persons

    P, t = take.absent.shape
    N = take.sampler.samples
    hypotheses = np.empty((P, N, t, 17, 3), np.float32)
    energy = np.empty((P, N, t), np.float32)
    median = np.empty((P, t, 17, 3), np.float32)
    prior = loaded_prior(prior_settings)
    started = time.perf_counter()
    lift_persons(prior=prior, take=take, hypotheses=hypotheses, median=median, energy=energy)
    with atomic_open(path) as stream:
        np.savez(stream, hypotheses=hypotheses, energy=energy)
    return time.perf_counter() - started
