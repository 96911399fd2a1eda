"""What identifies an input file's or folder's content for ``--resume``: checksums, not modification times.

Copies that keep or set old times (``cp -p``, ``rsync -a``, ``unzip``) must not hide a changed keypoint file, so
files up to ``HASHED_BYTES`` (keypoints, calibrations, root paths, offsets, priors) and every file of a folder are
stamped by their SHA-256; larger files (videos) by size and modification time, as reading them whole on every
``--resume`` would cost more than the check is worth.
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import replace
from pathlib import Path

from platypose.cli.runs.jobs import Job
from platypose.cli.runs.outputs import file_digest
from platypose.cli.runs.settings import RunSettings
from platypose.cli.terminal.options import as_json

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


def fingerprint(job: Job, settings: RunSettings) -> str:
    """A digest of the job's input files and the settings that decide whether it can succeed."""
    take = settings.take
    sync_file = Path(take.sync) if take.sync not in ("auto", "none") else None
    files = [v.source for v in job.views] + [
        p for p in (settings.cams, take.root_trajectory, settings.prior.path, sync_file) if p
    ]
    decisive = [
        take.sync,
        str(replace(settings.detect, threads=None)),
        take.persons,
        take.root,
        take.floor,
        settings.prior.runtime,
        settings.prior.device,
        as_json(take.sampler),
        as_json(take.windows),
        [input_stamp(Path(f)) for f in files],
        *([settings.split_seconds] if settings.split_seconds else []),  # seams: a split lift is another result
    ]
    return hashlib.sha256(json.dumps(decisive, sort_keys=True, default=str).encode()).hexdigest()
