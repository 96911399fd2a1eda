"""A job's outputs as one set: ``lift.json`` records each file's size and SHA-256, and goes first when a new set
moves in, so an interrupted switch (new files beside old ones) is never taken for a finished run.

The switch: the old ``lift.json`` is removed, the new files are renamed into place one by one, the new
``lift.json`` is written last. A kill in between leaves no ``lift.json`` (the job is run again by ``--resume``);
a file changed or replaced afterwards no longer matches its checksum.
"""

from __future__ import annotations

import hashlib
from collections.abc import Iterable
from pathlib import Path

CHUNK = 2**20


def file_digest(path: Path) -> dict:
    """``{"size": bytes, "sha256": hex}`` of the file at ``path``."""
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        while chunk := stream.read(CHUNK):
            digest.update(chunk)
    return {"size": path.stat().st_size, "sha256": digest.hexdigest()}


def digests(paths: Iterable[Path]) -> dict[str, dict]:
    """File name -> :func:`file_digest`, for a manifest's ``files``."""
    return {path.name: file_digest(path) for path in paths}


def changed_files(folder: Path, recorded: object) -> list[str] | None:
    """Names of the recorded files in ``folder`` whose size or checksum differ (missing ones too); None when
    ``recorded`` is not a manifest's ``files`` table (written by an older version, or damaged)."""
    if not isinstance(recorded, dict) or not all(isinstance(v, dict) for v in recorded.values()):
        return None
    changed = []
    for name, expected in recorded.items():
        path = folder / Path(str(name)).name
        if not path.is_file() or path.stat().st_size != expected.get("size") or file_digest(path) != expected:
            changed.append(path.name)
    return changed
