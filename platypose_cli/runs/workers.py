"""The processes that lift: how many threads each input gets, signals around long commands, and worker processes.

Threads: one per input by default, in ``lift``, ``demo`` and ``bench``. The rule, measured (docs/results.md,
"Default threads"): on the shared 2-core machine, with another CPU-bound process running, one thread per input
lifted the sports2d demo end to end many times faster than two (OpenMP threads spin while they wait for a core that
another process holds); on a quiet machine the small prior gains little from a second thread. A machine with cores
to spare runs more inputs at once instead (``--jobs``: one process per input, one thread each), which never
oversubscribes it. ``--threads`` overrides the rule.

Signals: SIGTERM is handled like Ctrl-C (so temporary files and staging folders are removed on the way out), and
worker processes end with the process that started them.
"""

from __future__ import annotations

import os
import signal
import sys
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

DEFAULT_THREADS = 1
PARENT_POLL_S = 1.0  # how often a worker looks whether its parent is still there
CLEANUP_S = 5.0  # then how long it has to unwind (remove its staging folder) before it ends regardless


def threads_for(given: int | None) -> int:
    """The threads an input gets: ``given`` (``--threads``), else ``DEFAULT_THREADS``."""
    return given if given is not None else DEFAULT_THREADS


def limit_threads(threads: int) -> None:
    """Cap torch's (and OpenMP's) threads in this process."""
    os.environ["OMP_NUM_THREADS"] = str(threads)
    import torch

    torch.set_num_threads(threads)


def worker_init(threads: int, parent: int) -> None:
    """A worker process: threads capped; Ctrl-C is left to the parent, SIGTERM unwinds (staging folders removed), and
    the worker ends when the parent is gone (even killed with SIGKILL)."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    signal.signal(signal.SIGTERM, lambda signum, frame: sys.exit(128 + signum))
    end_with_parent(parent)
    limit_threads(threads)


def _raise_interrupt(signum, frame) -> None:
    raise KeyboardInterrupt(f"signal {signum}")


@contextmanager
def terminate_as_interrupt() -> Iterator[None]:
    """SIGTERM is handled like Ctrl-C (KeyboardInterrupt) inside the block."""
    try:
        previous = signal.signal(signal.SIGTERM, _raise_interrupt)
    except ValueError:  # not the main thread: leave signals alone
        yield
        return
    try:
        yield
    finally:
        signal.signal(signal.SIGTERM, previous)


def end_with_parent(parent: int, poll_s: float = PARENT_POLL_S) -> None:
    """In a worker process started by process ``parent``: SIGTERM to itself once that parent is gone (a parent
    killed with SIGKILL cannot end its workers), so the worker unwinds as on SIGTERM instead of living on, and ends
    ``CLEANUP_S`` later in any case (a process pool's worker catches the SystemExit of its task and would wait for
    the next task for ever). A daemon thread watches; a parent gone before this call is noticed at once. What a
    worker could not remove is removed by the next run (staging folders of dead processes)."""

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(poll_s)
        os.kill(os.getpid(), signal.SIGTERM)
        time.sleep(CLEANUP_S)
        os._exit(128 + signal.SIGTERM)

    threading.Thread(target=watch, name="end-with-parent", daemon=True).start()
