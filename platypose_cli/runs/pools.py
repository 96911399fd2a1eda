"""The pools that run a split lift's piece tasks (:mod:`platypose.cli.runs.pieces`) in parallel: this machine's
processes (``--jobs N``) or Ray tasks (``--executor ray``). A piece task that fails is run again: once on this
machine, as Ray retries inputs on a cluster.
"""

from __future__ import annotations

import os
from collections.abc import Callable, Iterator, Sequence
from concurrent.futures import FIRST_COMPLETED, wait
from contextlib import contextmanager

from platypose.cli.runs.pieces import Task
from platypose.cli.runs.ray import RayOptions, check_fits, connected, ray_failure
from platypose.cli.runs.workers import limit_threads, worker_init
from platypose.lifting.errors import InputError

DEATHS = 2  # on this machine, a piece is run again after its worker died this many times (as Ray's max_retries)


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


@contextmanager
def ray_pieces(options: RayOptions, threads: int, quiet: bool) -> Iterator[RayPieces]:
    """Ray connected as ``options`` say, piece tasks of ``options.cpus_per_input`` CPUs each."""
    with connected(options, quiet) as ray:
        check_fits(ray, options.cpus_per_input)
        yield RayPieces(ray, options.cpus_per_input, options.max_retries, threads)
