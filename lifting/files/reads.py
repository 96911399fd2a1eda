"""Reading a small input file whole: only a regular file, and never more than a limit, counted while reading.

A FIFO, a character device or a socket given where a file is expected would block a reader for ever or feed it
without end, and its size from ``stat`` is 0; a regular file can also grow while it is read. So the file is opened
without waiting for a writer, refused unless it is a regular file, and read in chunks up to the limit.
"""

from __future__ import annotations

import json
import os
import stat
from pathlib import Path
from typing import Any

from platypose.lifting.errors import InputError

CHUNK = 2**20


def file_kind(mode: int) -> str:
    """What a ``st_mode`` names, in words (for messages)."""
    kinds = (
        (stat.S_ISDIR, "a folder"),
        (stat.S_ISFIFO, "a FIFO (named pipe)"),
        (stat.S_ISCHR, "a character device"),
        (stat.S_ISBLK, "a block device"),
        (stat.S_ISSOCK, "a socket"),
        (stat.S_ISLNK, "a symbolic link"),
    )
    return next((words for test, words in kinds if test(mode)), "not a regular file")


def read_regular(path: Path | str, limit: int, what: str = "file") -> bytes:
    """The bytes of the regular file ``path``; InputError naming it when it is missing, not a regular file, or
    longer than ``limit`` bytes (``what`` names the kind of file in the message)."""
    path = Path(path)
    try:
        handle = os.open(path, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except FileNotFoundError:
        raise InputError(f"{path}: {what} not found") from None
    except OSError as err:
        raise InputError(f"{path}: cannot read the {what} ({err.strerror or err})") from None
    with os.fdopen(handle, "rb") as stream:
        mode = os.fstat(stream.fileno()).st_mode
        if not stat.S_ISREG(mode):
            raise InputError(f"{path}: is {file_kind(mode)}, a regular {what} was expected")
        chunks, size = [], 0
        while chunk := stream.read(min(CHUNK, limit + 1 - size)):
            chunks.append(chunk)
            size += len(chunk)
            if size > limit:
                raise InputError(f"{path}: over {limit / 2**20:.0f} MiB, too large for a {what}")
    return b"".join(chunks)


def json_value(text: bytes | str) -> Any:
    """The JSON value of ``text``; ValueError saying in words why there is none: not JSON (not UTF-8, a syntax
    error), or arrays and tables nested deeper than Python's recursion allows (about a thousand levels), where
    ``json`` would raise RecursionError."""
    try:
        return json.loads(text)
    except RecursionError:
        raise ValueError("nested too deep") from None
    except ValueError as err:  # JSONDecodeError, UnicodeDecodeError
        raise ValueError(f"not JSON: {str(err).splitlines()[0][:80]}") from None


def check_readable_inputs(paths: list[Path], what: str = "input") -> None:
    """InputError naming the first of ``paths`` (following links) that is neither a regular file nor a folder, or a
    folder holding such an entry directly (a keypoint folder's files are read one by one): a FIFO, device or socket
    would block its reader or feed it without end. Missing paths are left to their readers' own messages."""
    for path in map(Path, paths):
        entries = [path]
        if path.is_dir():
            entries += sorted(path.iterdir())
        for entry in entries:
            try:
                mode = os.stat(entry).st_mode
            except OSError:
                continue
            if not (stat.S_ISREG(mode) or stat.S_ISDIR(mode)):
                raise InputError(f"{entry}: is {file_kind(mode)}, a regular {what} file was expected")
