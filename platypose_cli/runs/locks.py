"""Exclusive locks on files in ``--out`` (POSIX ``flock``; where there is none, no lock).

A lock file is opened only as a regular file platypose can create: never through a symbolic link, and without
waiting on a FIFO (which would block the open for ever); anything else in its place is refused with one line.
"""

from __future__ import annotations

import errno
import os
import stat
from collections.abc import Iterator
from contextlib import contextmanager, suppress
from pathlib import Path

from platypose.lifting.errors import InputError
from platypose.lifting.files.reads import file_kind

try:
    import fcntl
except ImportError:  # not POSIX: no lock
    fcntl = None


class Busy(InputError):
    """The lock is held by another process (and the caller chose not to wait)."""


def _open_lock_file(path: Path) -> int:
    flags = os.O_RDWR | os.O_CREAT | getattr(os, "O_NOFOLLOW", 0) | getattr(os, "O_NONBLOCK", 0)
    try:
        handle = os.open(path, flags | getattr(os, "O_CLOEXEC", 0), 0o644)
    except OSError as err:
        if err.errno == errno.ELOOP:
            raise InputError(f"{path}: is a symbolic link, not a lock file platypose made; remove it") from None
        if err.errno in (errno.ENXIO, errno.EISDIR):
            kind = "a folder" if err.errno == errno.EISDIR else file_kind(os.lstat(path).st_mode)
            raise InputError(f"{path}: is {kind}, not a lock file platypose made; remove it") from None
        raise
    mode = os.fstat(handle).st_mode
    if not stat.S_ISREG(mode):
        os.close(handle)
        raise InputError(f"{path}: is {file_kind(mode)}, not a lock file platypose made; remove it")
    return handle


def _still_there(handle: int, path: Path) -> bool:
    """Whether ``path`` still names the file open as ``handle`` (a holder removes its lock file on release)."""
    try:
        named = os.stat(path, follow_symlinks=False)
    except FileNotFoundError:
        return False
    held = os.fstat(handle)
    return (named.st_dev, named.st_ino) == (held.st_dev, held.st_ino)


def _locked_handle(path: Path, wait: bool, busy: str) -> int:
    """A handle of ``path`` holding its exclusive lock: locked, then checked to be still the file named ``path``
    (else the previous holder removed it meanwhile: open the new one and lock again)."""
    while True:
        handle = _open_lock_file(path)
        try:
            fcntl.flock(handle, fcntl.LOCK_EX | (0 if wait else fcntl.LOCK_NB))
        except BlockingIOError:
            os.close(handle)
            raise Busy(f"{path}: {busy}") from None
        if _still_there(handle, path):
            return handle
        os.close(handle)


@contextmanager
def exclusive_lock(path: Path, wait: bool = True, busy: str = "held by another process") -> Iterator[None]:
    """Hold an exclusive lock on the regular file ``path`` (created if missing) for the ``with`` block, and remove
    the file when done (no empty lock file is left behind; a process that opened it meanwhile locks anew).

    ``wait``: block until the lock is free; else raise :class:`Busy` (``path``: ``busy``) when another process
    holds it. InputError when ``path`` is a symbolic link, a FIFO, a device or a folder."""
    if fcntl is None:
        yield
        return
    path = Path(path)
    handle = _locked_handle(path, wait, busy)
    try:
        yield
    finally:
        if _still_there(handle, path):  # (else it went with its folder)
            with suppress(OSError):  # a lock file that cannot be removed stays, as before
                os.unlink(path)  # while still held: whoever locks the old file next sees it gone and starts over
        os.close(handle)  # releases the lock
