"""Run a file writer in a child process watched for a full disk, so a stuck writer can never hang this process.

rerun's file sink blocks forever (deaf to Ctrl-C) when the disk fills while it
writes: its flush waits for a writer thread that stopped. The recording is
therefore written by a child process; this process polls it and the free space
of the target's file system, and ends the child when the disk stays full
(``OSError`` ENOSPC for that file), when the child fails (its error is raised
here), or on Ctrl-C. On POSIX the child is forked (no re-import, no copy of
the data); it runs only numpy, rerun and PyAV code, never torch. Elsewhere it
is spawned, and the writer's arguments are pickled to it by this process. The
child's stderr goes to /dev/null (rerun and ffmpeg log there on their own);
its messages and errors come back through a pipe.
"""

from __future__ import annotations

import errno
import multiprocessing
import os
import shutil
import time
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

from platypose.lifting.errors import InputError

POLL_S = 0.1
FULL_BYTES = 256 * 1024  # free space under which the file system counts as full
FULL_GRACE_S = 1.5  # how long it must stay full while the writer runs before the writer is stopped


def free_bytes(folder: Path) -> int:
    """Free bytes for unprivileged users on the file system holding ``folder``."""
    return shutil.disk_usage(folder).free


def _child(conn, writer: Callable[..., None], args: tuple, path: Path) -> None:
    """Run ``writer(*args, path, say)`` and report ("done",) or the error; exit without running atexit hooks."""
    code = 0
    quiet = os.open(os.devnull, os.O_WRONLY)
    os.dup2(quiet, 2)  # rerun's and ffmpeg's own log lines: everything the writer has to say goes through ``conn``
    try:
        writer(*args, path, lambda message: conn.send(("say", str(message))))
        conn.send(("done",))
    except InputError as err:
        conn.send(("input", str(err)))
        code = 1
    except OSError as err:
        conn.send(("os", err.errno, err.strerror or str(err)))
        code = 1
    except BaseException as err:  # everything the writer raised is reported to the parent
        conn.send(("other", f"{type(err).__name__}: {err}"))
        code = 1
    finally:
        conn.close()
        # A writer thread stuck on a full disk would block the interpreter's normal shutdown.
        os._exit(code)


def _context():
    methods = multiprocessing.get_all_start_methods()
    return multiprocessing.get_context("fork" if "fork" in methods else "spawn")


def _full_disk(path: Path) -> OSError:
    return OSError(errno.ENOSPC, f"no space left on device while writing {path.name}", str(path))


def run_watched(
    writer: Callable[..., None],
    args: tuple[Any, ...],
    path: Path,
    say: Callable[[str], None] = lambda _: None,
    space: Callable[[Path], int] = free_bytes,
) -> None:
    """Call ``writer(*args, path, say)`` in a child process; return when it finished, raise what went wrong.

    InputError and OSError raised by the writer are raised here with their
    message; a disk that stays full is ``OSError(ENOSPC)`` naming ``path``; any
    other failure is ``OSError(EIO)`` naming ``path``. ``space`` reports the
    free bytes of a folder (replaceable for tests). Ctrl-C ends the child.
    """
    path = Path(path)
    if space(path.parent) < FULL_BYTES:
        raise _full_disk(path)
    receive, send = multiprocessing.Pipe(duplex=False)
    context = _context()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # Python 3.12+ warns on fork in a threaded process
        process = context.Process(target=_child, args=(send, writer, args, path), daemon=True)
        process.start()
    send.close()
    outcome: tuple | None = None
    full_since: float | None = None
    try:
        while outcome is None:
            if receive.poll(POLL_S):
                try:
                    message = receive.recv()
                except EOFError:  # the child died without a word
                    break
                if message[0] == "say":
                    say(message[1])
                else:
                    outcome = message
                continue
            if not process.is_alive() and not receive.poll(0):
                break
            if space(path.parent) < FULL_BYTES:
                full_since = full_since or time.monotonic()
                if time.monotonic() - full_since > FULL_GRACE_S:
                    raise _full_disk(path)
            else:
                full_since = None
    finally:
        receive.close()
        if process.is_alive():
            process.kill()
        process.join()
    _raise_outcome(outcome, process.exitcode, path, space)


def _raise_outcome(outcome: tuple | None, exitcode: int | None, path: Path, space: Callable[[Path], int]) -> None:
    if outcome is not None and outcome[0] == "done":
        return
    if outcome is not None and outcome[0] == "input":
        raise InputError(outcome[1])
    if outcome is not None and outcome[0] == "os":
        raise OSError(outcome[1], outcome[2], str(path))
    why = outcome[1] if outcome is not None else ""
    if space(path.parent) < FULL_BYTES or "os error 28" in why:
        raise _full_disk(path)
    why = outcome[1] if outcome is not None else f"the writer process ended with exit code {exitcode}"
    raise OSError(errno.EIO, f"could not write {path.name}: {why}", str(path))
