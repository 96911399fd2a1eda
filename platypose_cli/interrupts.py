"""Signals around long commands: SIGTERM handled like Ctrl-C (so temporary files and staging folders are removed on
the way out), and worker processes that end with the process that started them."""

from __future__ import annotations

import os
import signal
import threading
import time
from collections.abc import Iterator
from contextlib import contextmanager

PARENT_POLL_S = 1.0  # how often a worker looks whether its parent is still there
CLEANUP_S = 5.0  # then how long it has to unwind (remove its staging folder) before it ends regardless


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
