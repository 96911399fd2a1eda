"""What identifies an input file's or folder's content for ``--resume``: checksums, not modification times.

Copies that keep or set old times (``cp -p``, ``rsync -a``, ``unzip``) must not hide a changed keypoint file, so
files up to ``HASHED_BYTES`` (keypoints, calibrations, root paths, offsets, priors) and every file of a folder are
stamped by their SHA-256; larger files (videos) by size and modification time, as reading them whole on every
``--resume`` would cost more than the check is worth.
"""

from __future__ import annotations

from pathlib import Path

from platypose.cli.output_set import file_digest

HASHED_BYTES = 256 * 2**20


def _file_stamp(path: Path) -> list:
    stat = path.stat()
    if stat.st_size <= HASHED_BYTES:
        return [stat.st_size, file_digest(path)["sha256"]]
    return [stat.st_size, stat.st_mtime_ns]


def input_stamp(path: Path) -> list:
    """The stamp of a file or folder (its name and content); a missing path is stamped as missing."""
    if path.is_dir():
        files = sorted(p for p in path.rglob("*") if p.is_file())
        return [path.name, [[str(p.relative_to(path)), *_file_stamp(p)] for p in files]]
    if not path.is_file():
        return [path.name, None]
    return [path.name, *_file_stamp(path)]
