"""The driver's side of ``platypose lift --split-seconds S``: one take's detection and lifting spread over piece tasks
(:mod:`platypose.cli.runs.pieces`, run by a pool of :mod:`platypose.cli.runs.pools`) and joined into the arrays of
one unsplit result. :func:`split_executor` checks the option and makes the batch's executor (:class:`SplitExecutor`:
a batch's inputs one after another in the driver, each spread over the pool), which hands the job its hooks
(:func:`split_hooks`).

- **Detection** (:func:`detect_in_pieces`): the video is cut into stretches of S seconds, each detected by a task; the
  driver joins the detections (a few kB per frame) into the video's detection cache, the file an unsplit run
  writes, and the usual reader tracks them over the whole take. Tracking, ID repair, the persons choice and the gap
  rule therefore see the whole take: the same 2D, track ids and persons as an unsplit run.
- **Lifting** (:class:`SplitLifter`, in place of :func:`platypose.lifting.tracks.persons.lift_persons`): the take's 2D is cut
  into pieces of S seconds lifted with a margin either side (:func:`platypose.lifting.tracks.seams.plan_pieces`), each
  piece's persons present lifted by a task; the driver then reads the pieces in order (one piece in memory at a
  time), reorders each piece's hypotheses to continue the piece before and cross-fades them at the seam
  (:mod:`platypose.lifting.tracks.seams`), and writes them into the caller's arrays. Rigid people, the floor, the
  representative answer, plausibility flags and export then run on the whole take as in an unsplit run.
"""

from __future__ import annotations

import functools
import hashlib
import json
import math
import os
import pickle
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path

import numpy as np

from platypose.cli.runs.job import Hooks, run_job
from platypose.cli.runs.piece_files import read_lift_piece
from platypose.cli.runs.piece_plan import PiecePlan
from platypose.cli.runs.pieces import detect_piece, lift_piece, make_piece_folder, piece_folder
from platypose.cli.runs.pools import LocalPieces, ray_pieces
from platypose.cli.runs.workers import limit_threads, threads_for
from platypose.lifting.errors import InputError
from platypose.lifting.tracks.seams import join_pieces, plan_pieces

MIN_MARGIN_S = 1.0  # seconds each piece is lifted past its own frames, at least (and at least --max-gap)
MAX_SPLIT_S = 24 * 3600.0  # --split-seconds above a day is no piece of one take (as offsets are bounded)


def margin_seconds(max_gap: float) -> float:
    """Seconds a piece is lifted either side of its own frames: every gap the lift bridges then lies within one
    piece, and neighbours share twice this around their seam."""
    return max(MIN_MARGIN_S, float(max_gap))


def _digest(*parts) -> str:
    """A short digest of picklable ``parts`` (arrays by their bytes)."""
    h = hashlib.sha256()
    for part in parts:
        h.update(part.tobytes() if isinstance(part, np.ndarray) else pickle.dumps(part))
    return h.hexdigest()[:24]


def split_hooks(pool, settings, name: str, log, read: Callable) -> tuple[SplitLifter, Callable]:
    """For job ``name`` lifted with ``settings`` (RunSettings with ``split_seconds``) over ``pool``: the lifter
    :func:`platypose.pipeline.run_take` takes, and ``read`` (a view reader) preceded, for a video, by its detection
    in pieces into the detection cache ``read`` then finds (keypoint files are read whole)."""
    from platypose.detectors.sources.keypoint_source import is_keypoint_source

    folder = settings.out / name
    lifter = SplitLifter(pool, settings.prior, settings.split_seconds, piece_folder(settings.out, name), log)

    def split_read(source: Path):
        if not is_keypoint_source(source):
            detect_in_pieces(source, settings.detect, folder, settings.split_seconds, pool, log)
        return read(source)

    return lifter, split_read


def piece_hooks(pool, settings) -> Hooks:
    """The hooks :func:`platypose.cli.runs.job.run_job` takes for a job spread over ``pool`` (:func:`split_hooks`)."""
    return functools.partial(split_hooks, pool, settings)


def detect_in_pieces(source: Path, detect, folder: Path, split_s: float, pool, log) -> int:
    """Detect ``source`` (a video) in pieces of ``split_s`` seconds run by ``pool`` and write the joined detections
    as its detection cache in ``folder`` (nothing to do when that cache is current); pieces already detected by an
    earlier run (``folder/.pieces``) are not detected again, and a damaged cache or piece is removed, warned of
    (``log``, a JobLog) and detected again. The number of pieces detected now."""
    from platypose.cli.runs.models import cached_detector
    from platypose.detectors.cache import DetectionCache, cache_key, read_detections
    from platypose.detectors.sources.video import video_info
    from platypose.media import frame_stamps

    name = cached_detector(detect).name
    key = cache_key(source, name, detect.stride, detect.max_frames)
    cache = DetectionCache(folder, source.stem)
    if cache.load(key, log.warning) is not None:
        return 0
    info = video_info(source)
    stamps = frame_stamps(source)[0]
    step = max(int(round(split_s * info.fps / detect.stride)), 1) * detect.stride  # a multiple of the stride
    starts = list(range(0, max(len(stamps), 1), step))
    pieces = piece_folder(folder.parent, folder.name)
    make_piece_folder(pieces)
    plan = PiecePlan(pieces)
    tasks, paths, todo = [], [], []
    for n, start in enumerate(starts):
        count = None if n == len(starts) - 1 else step  # the last piece reads to the end, whatever the header says
        piece_key = json.dumps({"video": key, "start": start, "count": count})
        path = pieces / f"{source.stem}.{_digest(piece_key)}.detections.npz"
        paths.append(path)
        if os.path.lexists(path) and (why := plan.why_not(path)) is not None:
            log.warning(f"damaged split piece {source.name}:{n}: {path}: {why}; removed, detected again")
            path.unlink(missing_ok=True)
            plan.forget(path)
        if DetectionCache(path.parent, path.name.removesuffix(".detections.npz")).load(piece_key, log.warning) is None:
            stamp = int(stamps[start]) if start < len(stamps) else None
            tasks.append((detect_piece, (str(source), detect, start, stamp, count, str(path), piece_key)))
            todo.append(n)
    started = time.perf_counter()
    seconds = pool.run(tasks, [f"{source.name}:{n}" for n in todo], lambda i: plan.record(paths[todo[i]]), say=log)
    if tasks:
        log(
            f"{source}: {len(tasks)} piece(s) of {split_s:g} s detected {piece_times(seconds, time.perf_counter() - started)}"
        )
    detections, indices = [], []
    for path in paths:
        _, found, at = read_detections(path)
        detections += found
        indices.append(at)
    cache.save(key, detections, np.concatenate(indices) if indices else np.zeros(0, np.int64))
    return len(tasks)


class SplitLifter:
    """:func:`platypose.lifting.tracks.persons.lift_persons` spread over pieces of ``split_s`` seconds run by ``pool``, the
    pieces cached in ``folder`` (a piece lifted by an earlier run with the same inputs, whose digest the plan of
    pieces holds, is read back); ``prior`` (PriorSettings) is what the workers load. ``log`` (a JobLog) gets one
    line per call, and a warning for each damaged piece (removed and lifted again)."""

    def __init__(self, pool, prior, split_s: float, folder: Path, log) -> None:
        self.pool, self.prior, self.split_s, self.folder, self.log = pool, prior, split_s, folder, log

    def __call__(self, prior, take, hypotheses, median, energy, progress=None) -> None:
        """As ``lift_persons``: ``take`` (a Take: keypoints (C, T, P, 17, 3)) lifted into ``hypotheses``
        (P, N, T, 17, 3), ``median`` (P, T, 17, 3) and ``energy`` (P, N, T), NaN where its persons are ``absent``."""
        from platypose.lifting.take import Take

        keypoints, times, cameras, roots, absent = take.keypoints, take.times, take.cameras, take.roots, take.absent
        sampler, windows = take.sampler, take.windows
        margin = margin_seconds(windows.max_gap)
        pieces = plan_pieces(times, self.split_s, margin)
        make_piece_folder(self.folder)
        plan = PiecePlan(self.folder)

        def task(n: int) -> tuple[list[int], Path, tuple, np.ndarray]:
            """Piece n's persons present, its file, the task that lifts it, and where the piece has each of them (its
            own presence, (p, t))."""
            t = pieces[n].lifted
            who = [p for p in range(absent.shape[0]) if not absent[p, t].all()]
            piece = {
                "keypoints": np.ascontiguousarray(keypoints[:, t][:, :, who]),
                "times": np.asarray(times[t]),
                "track_ids": np.asarray(take.track_ids)[who],
                "cameras": list(cameras),
                "roots": [None if roots[p] is None else np.asarray(roots[p][t]) for p in who],
            }
            key = _digest(prior.checksum, self.prior, piece["keypoints"], piece["times"],
                          np.ascontiguousarray(absent[who][:, t]), piece["roots"], piece["cameras"], sampler, windows)  # fmt: skip
            path = self.folder / f"lift.{key}.npz"
            # the piece's own presence: a gap at its edge is not lifted through (its other end lies outside)
            inputs = Take.on_clock(**piece, sampler=sampler, windows=windows)
            return who, path, (lift_piece, (self.prior, inputs, str(path))), ~inputs.absent

        def name(n: int) -> str:
            return f"{n} (frames {pieces[n].lifted.start}-{pieces[n].lifted.stop - 1})"

        tasks, todo, paths, persons, presences = [], [], [], [], []
        for n in range(len(pieces)):
            who, path, work, present = task(n)
            paths.append(path)
            persons.append(who)
            presences.append(present)
            if who and os.path.lexists(path) and (why := plan.why_not(path)) is not None:
                self._drop(plan, path, f"piece {name(n)}: {path}: {why}")
            if who and not os.path.lexists(path):
                tasks.append(work)
                todo.append(n)
        P = absent.shape[0]
        earlier = sum(1 for who in persons if who) - len(tasks)
        self.log(
            f"lifting in {len(pieces)} piece(s) of {self.split_s:g} s (+{margin:g} s either side), "
            f"{earlier} done earlier"
        )
        done = [0]

        def each(i: int) -> None:
            plan.record(paths[todo[i]])
            done[0] += 1
            if progress is not None:
                progress(list(range(P)), done[0], len(tasks))

        started = time.perf_counter()
        seconds = self.pool.run(tasks, [name(n) for n in todo], each, say=self.log)
        if tasks:
            self.log(f"{len(tasks)} piece(s) lifted {piece_times(seconds, time.perf_counter() - started)}")

        def load(n: int) -> tuple[np.ndarray, np.ndarray]:
            """Piece n's arrays, checked against the piece's own presence (a gap cut by its edge is NaN there: the
            neighbour that holds the whole gap lifts it); a piece that fails the checks is removed and lifted once
            more."""
            who, path, present = persons[n], paths[n], presences[n]
            if not who:
                return np.zeros((0, 0, 0, 17, 3), np.float32), np.zeros((0, 0, 0), np.float32)
            try:
                return read_lift_piece(path, present, sampler.samples)
            except ValueError as err:
                self._drop(plan, path, f"piece {name(n)}: {path}: {err}")
            self.pool.run([task(n)[2]], [name(n)], lambda i: plan.record(path), say=self.log)
            return read_lift_piece(path, present, sampler.samples)

        join_pieces(
            pieces, persons, load, times, absent, margin=margin, hypotheses=hypotheses, median=median, energy=energy
        )

    def _drop(self, plan: PiecePlan, path: Path, why: str) -> None:
        """Remove a damaged piece file and its line in the plan, warning ``why``."""
        self.log.warning(f"damaged split {why}; removed, lifted again")
        path.unlink(missing_ok=True)
        plan.forget(path)


def piece_times(seconds: Sequence[float | None], wall: float) -> str:
    """How long pieces took: the wall time of them all, and each on its worker (median, largest)."""
    each = np.array([s for s in seconds or [] if s is not None])
    told = f", each {np.median(each):.1f} s median, {each.max():.1f} s at most on its worker" if len(each) else ""
    return f"in {wall:.1f} s{told}"


class SplitExecutor:
    """Runs a batch's inputs one after another in this process, each split into pieces run by ``pool``:
    ``executor(jobs, todo, settings, record, bar)`` as :func:`platypose.cli.runs.batch.run_batch` calls it."""

    def __init__(self, make_pool: Callable[[int, bool], object]) -> None:
        self.make_pool = make_pool

    def __call__(self, jobs, todo, settings, record, bar) -> None:
        if not todo:
            return
        threads = threads_for(settings.detect.threads)
        limit_threads(threads)
        here = replace(settings, detect=replace(settings.detect, threads=threads))
        with self.make_pool(threads, settings.quiet) as pool:
            for index in todo:
                record(index, run_job(jobs[index], here, hooks=piece_hooks(pool, here)))
                bar.update(1)


def split_executor(split_s: float, max_gap: float, jobs: int, ray_options, collect: bool) -> SplitExecutor:
    """The executor of ``--split-seconds split_s``: pieces on ``jobs`` processes here, or on Ray (``ray_options``
    not None); InputError naming the problem for a value or combination that cannot be split."""
    shared = 2 * margin_seconds(max_gap)
    if not math.isfinite(split_s) or split_s <= 0:
        raise InputError(f"--split-seconds {split_s:g}: give a length in seconds above 0")
    if split_s > MAX_SPLIT_S:
        raise InputError(f"--split-seconds {split_s:g}: give at most {MAX_SPLIT_S:g} seconds (a day)")
    if split_s < shared:
        raise InputError(
            f"--split-seconds {split_s:g}: shorter than the {shared:g} s two neighbouring pieces share "
            f"(twice the larger of {margin_seconds(0):g} s and --max-gap); give at least {shared:g}"
        )
    if collect:
        raise InputError("--split-seconds: not with --collect; the pieces of an input meet in --out, shared storage")
    if ray_options is not None:
        return SplitExecutor(lambda threads, quiet: ray_pieces(ray_options, threads, quiet))
    if jobs < 2:
        raise InputError("--split-seconds: the pieces run in parallel; add --jobs N (N >= 2) or --executor ray")
    return SplitExecutor(lambda threads, quiet: LocalPieces(jobs, threads))
