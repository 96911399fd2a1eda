"""``platypose lift --split-seconds S``: the pieces of one input run as parallel tasks, on this machine's processes
(``--jobs N``) or as Ray tasks (``--executor ray``), their results cached as files under ``OUT/<name>/.pieces/``.

Two kinds of piece task: :func:`detect_piece` detects the frames of one stretch of a video, :func:`lift_piece` lifts
the persons of one stretch of a take's 2D. Each writes its result atomically into the piece folder under a name
that digests everything it depends on, so a resumed run finds the pieces that finished and redoes only the others;
the folder goes when the input's files are written. A piece task that fails is run again: once on this machine, as
Ray retries inputs on a cluster. :class:`SplitExecutor` runs a batch's inputs one after another in the driver, each
spread over the pool (:mod:`platypose.cli.split_join` joins the pieces).
"""

from __future__ import annotations

import math
import os
import shutil
import stat
import time
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, wait
from contextlib import contextmanager, suppress
from dataclasses import replace
from pathlib import Path

import numpy as np

from platypose.lifting.errors import InputError
from platypose.lifting.files.reads import file_kind

MAX_SPLIT_S = 24 * 3600.0  # --split-seconds above a day is no piece of one take (as offsets are bounded)
DEATHS = 2  # on this machine, a piece is run again after its worker died this many times (as Ray's max_retries)
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
    from platypose.cli.detection import cached_detector
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


def lift_piece(prior_settings, inputs: dict, path: str) -> float:
    """Lift one stretch of a take (:func:`platypose.lifting.tracks.persons.lift_persons` on ``inputs``: keypoints, times,
    cameras, roots, absent, config, windows) with the prior of ``prior_settings``; save its hypotheses and energy
    (float32, NaN where absent) atomically at ``path``. The seconds it took (the prior loaded, once per process)."""
    from platypose.cli.lift_run import _prior
    from platypose.lifting.files.atomic import atomic_open
    from platypose.lifting.tracks.persons import lift_persons

    P, t = inputs["absent"].shape
    N = inputs["config"].samples
    hypotheses = np.empty((P, N, t, 17, 3), np.float32)
    energy = np.empty((P, N, t), np.float32)
    median = np.empty((P, t, 17, 3), np.float32)
    prior = _prior(prior_settings)
    started = time.perf_counter()
    lift_persons(
        prior, inputs["keypoints"], inputs["times"], inputs["cameras"], inputs["roots"],
        inputs["absent"], inputs["config"], inputs["windows"], hypotheses, median, energy,
    )  # fmt: skip
    with atomic_open(path) as stream:
        np.savez(stream, hypotheses=hypotheses, energy=energy)
    return time.perf_counter() - started


def _retry_message(name: str, err: BaseException, attempts: int) -> str:
    return f"piece {name} failed {attempts} times: {type(err).__name__}: {' '.join(str(err).split())}"


class LocalPieces:
    """Piece tasks in ``workers`` spawned processes of this machine (each with ``threads`` threads); a task that raises
    other than for bad input is run once more, and the tasks of a pool whose worker died are run again in a new one."""

    def __init__(self, workers: int, threads: int) -> None:
        self.workers, self.threads, self.pool = workers, threads, None

    def _new_pool(self):
        import multiprocessing
        from concurrent.futures import ProcessPoolExecutor

        from platypose.cli.lift_batch import worker_init

        context = multiprocessing.get_context("spawn")
        args = (self.threads, os.getpid())
        return ProcessPoolExecutor(self.workers, mp_context=context, initializer=worker_init, initargs=args)

    def __enter__(self) -> LocalPieces:
        self.pool = self._new_pool()
        return self

    def __exit__(self, *failure) -> None:
        for process in list((getattr(self.pool, "_processes", None) or {}).values()):
            if failure[0] is not None:
                process.terminate()
        self.pool.shutdown(wait=True, cancel_futures=True)

    def run(
        self,
        tasks: Sequence[Task],
        names: Sequence[str],
        each: Callable[[int], None] = lambda i: None,
        say: Callable[[str], None] = lambda _: None,
    ) -> list:
        """Run ``tasks``; their results in task order, ``each(i)`` as task i finishes. InputError of a task is raised as it is; a task that raises
        twice, or is in the pool when a worker dies ``DEATHS`` times, raises RuntimeError naming it. Each task run
        again is said (``say``: the job's log)."""
        from concurrent.futures.process import BrokenProcessPool

        futures = {self.pool.submit(fn, *args): (i, 0, 0) for i, (fn, args) in enumerate(tasks)}
        results: list = [None] * len(tasks)
        while futures:
            done, _ = wait(list(futures), return_when=FIRST_COMPLETED)
            for future in done:
                if future not in futures:  # started again in a new pool
                    continue
                i, failed, deaths = futures.pop(future)
                try:
                    results[i] = future.result()
                except InputError:
                    raise
                except BrokenProcessPool as err:  # a worker died: every task still in the pool starts again
                    if deaths >= DEATHS:
                        raise RuntimeError(_retry_message(names[i], err, DEATHS + 1)) from err
                    self.pool.shutdown(wait=False, cancel_futures=True)
                    self.pool = self._new_pool()
                    again = [(i, failed, deaths)] + list(futures.values())
                    held = ", ".join(names[j] for j, _, _ in again)
                    say(f"a worker process died; running piece(s) {held} again in new processes")
                    futures = {self.pool.submit(*_call(tasks[j])): (j, f, d + 1) for j, f, d in again}
                except Exception as err:
                    if failed >= 1:
                        raise RuntimeError(_retry_message(names[i], err, 2)) from err
                    say(
                        f"piece {names[i]} failed ({type(err).__name__}: {' '.join(str(err).split())}); running it again"
                    )
                    futures[self.pool.submit(*_call(tasks[i]))] = (i, failed + 1, deaths)
                else:
                    each(i)
        return results


def _call(task: Task) -> tuple:
    """A task as ``submit`` takes it: the function, then its arguments."""
    return (task[0], *task[1])


def on_ray_worker(fn: Callable, args: tuple, threads: int, cwd: str):
    """A piece task on a Ray worker: the driver's working folder (relative paths), ``threads`` threads."""
    from platypose.cli.lift_batch import limit_threads

    if os.path.isdir(cwd):
        os.chdir(cwd)
    limit_threads(threads)
    return fn(*args)


class RayPieces:
    """Piece tasks as Ray tasks of ``cpus`` CPUs each; Ray runs a task again (``max_retries`` times) when its worker
    dies or it raises."""

    def __init__(self, ray, cpus: int, max_retries: int, threads: int) -> None:
        self.ray, self.cpus, self.max_retries, self.threads = ray, cpus, max_retries, threads

    def __enter__(self) -> RayPieces:
        return self

    def __exit__(self, *failure) -> None:
        return None

    def run(
        self,
        tasks: Sequence[Task],
        names: Sequence[str],
        each: Callable[[int], None] = lambda i: None,
        say: Callable[[str], None] = lambda _: None,
    ) -> list:
        """As :meth:`LocalPieces.run`; Ray runs a task again by itself, out of sight of ``say``."""
        from platypose.cli.lift_ray import ray_failure

        ray = self.ray
        remote = ray.remote(num_cpus=self.cpus, max_retries=self.max_retries, retry_exceptions=True)(on_ray_worker)
        cwd = os.getcwd()
        refs = {
            remote.options(name=f"piece:{names[i]}").remote(fn, args, self.threads, cwd): i
            for i, (fn, args) in enumerate(tasks)
        }
        pending = list(refs)
        results: list = [None] * len(tasks)
        try:
            while pending:
                done, pending = ray.wait(pending, num_returns=1, timeout=None)
                for ref in done:
                    try:
                        results[refs[ref]] = ray.get(ref)
                    except ray.exceptions.RayError as err:
                        cause = getattr(err, "cause", None)
                        if isinstance(cause, InputError):
                            raise cause from None
                        raise RuntimeError(f"piece {names[refs[ref]]}: Ray gave up: {ray_failure(err)}") from None
                    each(refs[ref])
        except BaseException:
            for ref in pending:
                ray.cancel(ref, force=True)
            raise
        return results


class SplitExecutor:
    """Runs a batch's inputs one after another in this process, each split into pieces run by ``pool``:
    ``executor(jobs, todo, settings, record, bar)`` as :func:`platypose.cli.lift_batch.run_batch` calls it."""

    def __init__(self, make_pool: Callable[[int, bool], object]) -> None:
        self.make_pool = make_pool

    def __call__(self, jobs, todo, settings, record, bar) -> None:
        from platypose.cli.lift_batch import limit_threads
        from platypose.cli.lift_run import run_job
        from platypose.cli.threads import threads_for

        if not todo:
            return
        threads = threads_for(settings.detect.threads)
        limit_threads(threads)
        here = replace(settings, detect=replace(settings.detect, threads=threads))
        with self.make_pool(threads, settings.quiet) as pool:
            for index in todo:
                record(index, run_job(jobs[index], here, pieces=pool))
                bar.update(1)


@contextmanager
def ray_pieces(options, threads: int, quiet: bool) -> Iterator[RayPieces]:
    """Ray connected as ``options`` (RayOptions) say, piece tasks of ``options.cpus_per_input`` CPUs each."""
    from platypose.cli.lift_ray import RayExecutor, connected

    with connected(options, quiet) as ray:
        RayExecutor(options)._check_fits(ray)
        yield RayPieces(ray, options.cpus_per_input, options.max_retries, threads)


def split_executor(split_s: float, max_gap: float, jobs: int, ray_options, collect: bool) -> SplitExecutor:
    """The executor of ``--split-seconds split_s``: pieces on ``jobs`` processes here, or on Ray (``ray_options``
    not None); InputError naming the problem for a value or combination that cannot be split."""
    from platypose.cli.split_join import margin_seconds

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
