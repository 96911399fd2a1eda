"""Atomic file writes: write a temporary file in the target's folder, then rename it over the target.

Only a regular file (or a new name) is replaced that way. A character device (``/dev/null``, ``/dev/stdout``) or a
FIFO with a reader is written through, as a shell redirection would; a symbolic link, a socket, a block device or a
folder in the target's place is refused (InputError): renaming over them would replace a link that may point
anywhere, or a device file of the machine (``--json /dev/full`` run as root).
"""

from __future__ import annotations

import errno
import os
import stat
import tempfile
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import IO, Any

from platypose.lifting.errors import InputError
from platypose.lifting.files.reads import file_kind


def existing_kind(target: Path | str, streams: bool = True) -> str | None:
    """What is at ``target``: None (nothing), ``file`` (a regular file, replaced by a rename) or, when ``streams``,
    ``stream`` (a character device or FIFO, written through); InputError naming ``target`` for anything else."""
    try:
        mode = os.lstat(target).st_mode
    except (FileNotFoundError, NotADirectoryError):
        return None
    if stat.S_ISREG(mode):
        return "file"
    if streams and (stat.S_ISCHR(mode) or stat.S_ISFIFO(mode)):
        return "stream"
    raise InputError(f"{target}: is {file_kind(mode)}; platypose does not replace it (remove it or write elsewhere)")


def check_writable(target: Path | str, folder: bool = False) -> Path:
    """Make sure ``target`` (a file, or a ``folder``) can be written before any work starts.

    Creates the missing parent folders (and ``target`` itself when ``folder``) and a
    temporary file in the folder the output goes to; raises InputError naming
    ``target`` when it is of the wrong kind or cannot be written (read-only,
    full, a file in the way, a name too long).
    """
    target = Path(target)
    if folder and target.exists() and not target.is_dir():
        raise InputError(f"{target}: is a file, an output folder was expected")
    if not folder and target.is_dir():
        raise InputError(f"{target}: is a folder, an output file name was expected")
    if not folder and existing_kind(target) == "stream":  # InputError for a symbolic link, a socket, ...
        return target  # a device or FIFO is written through: nothing is created beside it
    where = target if folder else target.parent
    try:
        where.mkdir(parents=True, exist_ok=True)
        if not folder and len(os.fsencode(target.name)) + 16 > os.pathconf(where, "PC_NAME_MAX"):
            raise OSError(errno.ENAMETOOLONG, "file name too long")
        handle, name = tempfile.mkstemp(prefix=".write-check.", dir=where)
        os.close(handle)
        os.unlink(name)
    except OSError as err:
        blocker = next((p for p in (where, *where.parents) if p.exists() and not p.is_dir()), None)
        if blocker is not None:
            raise InputError(f"{target}: cannot write there ({blocker} is a file, not a folder)") from None
        raise InputError(f"{target}: cannot write there ({err.strerror or err})") from None
    return target


@contextmanager
def atomic_path(target: Path | str, streams: bool = True) -> Iterator[Path]:
    """Yield a temporary path beside ``target``; on success it replaces ``target`` (mode 644), else it is removed.

    A character device or a FIFO at ``target`` is yielded itself (written through; refused unless ``streams``, for
    writers that rename files of their own onto the path); InputError for a FIFO without a reader (the write would
    wait for ever) and for what :func:`existing_kind` refuses."""
    target = Path(target)
    if existing_kind(target, streams) == "stream":
        with _stream(target):
            yield target
        return
    target.parent.mkdir(parents=True, exist_ok=True)
    # The temporary name is at most ~80 characters, so any target name the file system takes works.
    handle, name = tempfile.mkstemp(prefix=f".{target.name[:64]}.", suffix=".tmp", dir=target.parent)
    os.close(handle)
    tmp = Path(name)
    try:
        yield tmp
        os.chmod(tmp, 0o644)
        os.replace(tmp, target)
    except OSError as err:
        if err.filename is None or str(err.filename) == str(tmp):  # name the target, not the temporary file
            raise OSError(err.errno, err.strerror or str(err), str(target)) from None
        raise
    finally:
        tmp.unlink(missing_ok=True)


@contextmanager
def _stream(target: Path) -> Iterator[None]:
    """Hold ``target`` (a device or FIFO) open for writing while it is written: a FIFO without a reader is refused
    at once, and its reader does not see the end of the stream between the check and the write."""
    try:
        handle = os.open(target, os.O_WRONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as err:
        if err.errno == errno.ENXIO:
            raise InputError(f"{target}: a FIFO (named pipe) that no one reads; start its reader first") from None
        raise OSError(err.errno, err.strerror, str(target)) from None
    try:
        yield
    finally:
        os.close(handle)


@contextmanager
def atomic_open(target: Path | str, mode: str = "wb", **open_args: Any) -> Iterator[IO]:
    """Open a temporary file beside ``target`` with ``open(mode, **open_args)``; it replaces ``target`` on success."""
    with atomic_path(target) as tmp, open(tmp, mode, **open_args) as stream:
        yield stream


def write_text_atomic(target: Path | str, text: str) -> Path:
    """Write ``text`` (UTF-8; undecodable bytes of file names, kept as surrogates, as ``\\udcff``) to ``target``
    atomically and return the path."""
    with atomic_open(target, "w", encoding="utf-8", errors="backslashreplace") as stream:
        stream.write(text)
    return Path(target)


def same_file(a: Path | str, b: Path | str) -> bool:
    """Whether paths ``a`` and ``b`` name one file (the same resolved path, or links to one file)."""
    a, b = Path(a), Path(b)
    if a.resolve() == b.resolve():
        return True
    try:
        return os.path.samefile(a, b)
    except OSError:
        return False
