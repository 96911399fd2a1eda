"""A prior written in pieces: the small JSON index at the checkpoint's path, checked whole before any piece is read.

The index names each piece (a file beside it), its size and sha256, and the joined checkpoint's size and sha256.
A damaged or crafted index could name one piece thousands of times, a piece linked to a huge file elsewhere, or
sizes of ``1e400``; so before any piece is read, the index's entries must be of their types, their sizes must sum
to its total, the total must be within ``MAX_CHECKPOINT_BYTES``, no file may be named twice, each piece must be
a regular file in the index's own folder (a link leading out of it is refused) of the size the index says. Only
then are the pieces read, each bounded by its size, and checked against its sha256.
"""

from __future__ import annotations

import hashlib
import os
import re
import stat
from dataclasses import dataclass
from pathlib import Path

from platypose.lifting.errors import InputError
from platypose.lifting.files.reads import file_kind, json_value, read_regular

PIECES_FORMAT = "platypose-prior-pieces"
MAX_CHECKPOINT_BYTES = 4 * 2**30  # 2**28 float32 weights (checks.MAX_PARAMETERS) with an optimiser's state
MAX_INDEX_BYTES = 2**20  # an index lists a few hundred pieces in a few kB
MAX_PIECES = 10_000
_SHA256 = re.compile(r"[0-9a-f]{64}")


@dataclass(frozen=True)
class Piece:
    """One piece the index names: its file (a bare name beside the index), size and sha256."""

    file: str
    size: int
    sha256: str


def is_pieces_index(head: bytes) -> bool:
    """Whether a checkpoint file starting with ``head`` is the index of a prior written in pieces."""
    return head.lstrip()[:1] == b"{" and PIECES_FORMAT.encode() in head


def _whole(value: object) -> bool:
    return isinstance(value, int) and not isinstance(value, bool) and value >= 0


def _is_sha256(value: object) -> bool:
    return isinstance(value, str) and _SHA256.fullmatch(value) is not None


def _piece(entry: object) -> Piece | None:
    """The piece an index entry describes, or None when a field is missing or not of its type."""
    if not isinstance(entry, dict):
        return None
    file, size, digest = entry.get("file"), entry.get("bytes"), entry.get("sha256")
    if not (isinstance(file, str) and _whole(size) and _is_sha256(digest)):
        return None
    return Piece(file, size, digest)


def read_index(path: Path, text: bytes) -> tuple[list[Piece], int, str]:
    """The pieces, total size and sha256 the index ``text`` (read from ``path``) states; InputError naming the file
    when it is not JSON, nested too deep, or a field is missing or not of its type."""
    if len(text) > MAX_INDEX_BYTES:
        raise InputError(f"{path}: index of prior pieces over {MAX_INDEX_BYTES // 2**20} MiB")
    try:
        index = json_value(text)
    except ValueError as err:
        raise InputError(f"{path}: damaged index of prior pieces ({err})") from None
    fields = index if isinstance(index, dict) else {}
    entries = fields.get("pieces")
    pieces = [_piece(entry) for entry in entries] if isinstance(entries, list) else []
    total, checksum = fields.get("bytes"), fields.get("sha256")
    if not pieces or None in pieces or not _whole(total) or not _is_sha256(checksum):
        raise InputError(
            f"{path}: damaged index of prior pieces (it must give its bytes and sha256, and each piece's file, "
            "bytes and sha256)"
        )
    return pieces, total, checksum


def check_pieces(path: Path, pieces: list[Piece], total: int) -> list[Path]:
    """The files of ``pieces`` beside the index ``path``, once all are checked (nothing is read): at most
    ``MAX_PIECES`` of them summing to ``total`` within ``MAX_CHECKPOINT_BYTES``, none named twice, each a regular
    file in the index's folder of its stated size; InputError naming the index and the piece otherwise."""
    if len(pieces) > MAX_PIECES:
        raise InputError(f"{path}: the index names {len(pieces):,} pieces, over the {MAX_PIECES:,} a prior may have")
    if total > MAX_CHECKPOINT_BYTES:
        raise InputError(
            f"{path}: the index claims {total:,} bytes, over the {MAX_CHECKPOINT_BYTES:,} a prior may have"
        )
    if sum(p.size for p in pieces) != total:
        raise InputError(f"{path}: the index's piece sizes do not sum to its {total:,} bytes")
    folder = Path(os.path.realpath(path.parent))
    files, seen = [], set()
    for number, piece in enumerate(pieces, start=1):
        where = f"{path}: piece {number} of {len(pieces)} ({piece.file})"
        file = path.parent / piece.file
        if Path(piece.file).name != piece.file or piece.file in ("", ".", ".."):
            raise InputError(f"{where} is not a file name beside the index")
        real = Path(os.path.realpath(file))
        if real.parent != folder:
            raise InputError(f"{where} is a link leading out of the index's folder")
        if real in seen:
            raise InputError(f"{where} is named twice")
        seen.add(real)
        try:
            status = os.stat(real)
        except OSError:
            raise InputError(f"{where} is missing") from None
        if not stat.S_ISREG(status.st_mode):
            raise InputError(f"{where} is {file_kind(status.st_mode)}, not a piece")
        if status.st_size != piece.size:
            raise InputError(f"{where} has {status.st_size} bytes, the index says {piece.size} (truncated or replaced)")
        files.append(real)
    return files


def join_pieces(path: Path, index_text: bytes) -> bytes:
    """The checkpoint a pieces index ``path`` names, its pieces (beside it) checked first (:func:`check_pieces`),
    then read in order, each bounded by its size and checked against its sha256; InputError naming the file and
    the piece that is missing, truncated or not the one the index names (damaged or out of order)."""
    pieces, total, checksum = read_index(path, index_text)
    parts = []
    for number, (piece, file) in enumerate(zip(pieces, check_pieces(path, pieces, total)), start=1):
        where = f"{path}: piece {number} of {len(pieces)} ({piece.file})"
        data = read_regular(file, piece.size, "prior piece")
        if len(data) != piece.size:
            raise InputError(f"{where} has {len(data)} bytes, the index says {piece.size} (truncated or replaced)")
        if hashlib.sha256(data).hexdigest() != piece.sha256:
            raise InputError(f"{where} is not the piece the index names (pieces reordered or damaged)")
        parts.append(data)
    joined = b"".join(parts)
    if hashlib.sha256(joined).hexdigest() != checksum:
        raise InputError(f"{path}: the joined pieces are not the checkpoint the index names")
    return joined


def listed_pieces(path: Path, own_name: re.Pattern) -> set[Path]:
    """The pieces the index at ``path`` lists whose names ``own_name`` matches in full (the names the writer
    makes), beside it; empty when ``path`` is missing, not an index or a damaged one. What the writer may remove
    when it replaces the checkpoint: never a file the index does not name, nor one of another form."""
    try:
        text = read_regular(path, MAX_INDEX_BYTES, "prior checkpoint")
        pieces = read_index(path, text)[0] if is_pieces_index(text[:256]) else []
    except InputError:
        return set()
    return {path.parent / p.file for p in pieces if own_name.fullmatch(p.file)}
