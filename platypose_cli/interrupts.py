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


def end_with_parent(poll_s: float = PARENT_POLL_S) -> None:
    """In a worker process: SIGTERM to itself once its parent is gone (a parent killed with SIGKILL cannot end its
    workers), so the worker unwinds as on SIGTERM instead of living on; a daemon thread watches."""
    parent = os.getppid()

    def watch() -> None:
        while os.getppid() == parent:
            time.sleep(poll_s)
        os.kill(os.getpid(), signal.SIGTERM)

    threading.Thread(target=watch, name="end-with-parent", daemon=True).start()
