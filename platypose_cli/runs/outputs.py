"""A job's outputs: written into a staging folder, exported, moved into ``OUT/<name>/`` as one set.

Files are exported into a staging folder ``.<name>.<pid>.*.partial`` beside the job's folder (removed with whatever
is left in it at the end; a later run removes the ones of killed runs), then moved in. The set: ``lift.json`` records each file's size and SHA-256, and goes first when a new set
moves in, so an interrupted switch (new files beside old ones) is never taken for a finished run.

The switch: the old ``lift.json`` is removed, the new files are renamed into place one by one, the new
``lift.json`` is written last. A kill in between leaves no ``lift.json`` (the job is run again by ``--resume``);
a file changed or replaced afterwards no longer matches its checksum.
"""

from __future__ import annotations

import glob
import hashlib
import os
import shutil
import tempfile
from collections.abc import Iterable, Iterator
from contextlib import contextmanager
from pathlib import Path

from platypose.cli.runs.records import MANIFEST, read_record, valid_manifest
from platypose.lifting.files.atomic import existing_kind
from platypose.lifting.job_log import JobLog

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


@contextmanager
def staging_folder(folder: Path, name: str) -> Iterator[Path]:
    """A new staging folder ``.<name>.<pid>.*.partial`` beside ``folder`` (created if needed), removed with whatever
    is left in it at the end; staging folders of ``name`` left by processes that are gone are removed first."""
    folder.mkdir(parents=True, exist_ok=True)
    remove_stale_staging(folder.parent, name)
    prefix = f".{_short(name)}.{os.getpid()}."
    staging = Path(tempfile.mkdtemp(prefix=prefix, suffix=".partial", dir=folder.parent))
    try:
        yield staging
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def _short(name: str) -> str:
    """The job name as staging folders carry it: at most 64 characters, so any output name the file system takes
    also fits in a staging folder's name."""
    return name[:64]


def _alive(pid: int) -> bool:
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OSError):
        return True
    return True


def remove_stale_staging(out: Path, name: str, owners_gone: bool = False) -> list[str]:
    """Remove the staging folders of job ``name`` in ``out`` whose process is gone (killed runs); their names.

    ``owners_gone``: every earlier run of the job is known to be dead (a Ray retry, whose dead attempt may have run
    on another node, where its process id says nothing), so all its staging folders go."""
    removed = []
    short = _short(name)
    for path in out.glob(f".{glob.escape(short)}.*.partial"):
        owner = path.name[len(short) + 2 :].split(".", 1)[0]
        if path.is_dir() and (owners_gone or not (owner.isdigit() and _alive(int(owner)))):
            shutil.rmtree(path, ignore_errors=True)
            removed.append(path.name)
    return removed


def output_patterns(name: str) -> list[str]:
    """Glob patterns of every file a lift of job ``name`` may write into its folder."""
    stem = glob.escape(name)
    ends = (".npz", ".csv", "_hypotheses.csv", ".rrd", "_gaps.json", "_angles.csv", "_report.png")
    fixed = [f"{stem}{end}" for end in (*ends, "_summary.csv")]  # _summary.csv: an older lift's, removed as stale
    return fixed + [f"{stem}_p*.{ext}" for ext in ("bvh", "trc", "c3d", "mot", "osim")]


def remove_stale_outputs(folder: Path, name: str, written: list[Path]) -> list[str]:
    """Remove output files of an earlier run in ``folder`` that this run did not write (a person or format gone)."""
    keep = {p.name for p in written}
    stale = {p for pattern in output_patterns(name) for p in folder.glob(pattern) if p.is_file() and p.name not in keep}
    for path in stale:
        path.unlink(missing_ok=True)
    return sorted(p.name for p in stale)


def export_atomically(
    result, videos, staging: Path, folder: Path, name: str, formats, log: JobLog, *, playable=None
) -> list[Path]:
    """Export into ``staging``, then move every file written into ``folder``; returns the final paths. ``playable``:
    the videos already re-encoded for the recording (:func:`platypose.exporters.export`)."""
    from platypose.exporters import export

    written = export(result, staging, name, formats, videos, say=log, warn=log.warning, playable=playable)
    (folder / MANIFEST).unlink(missing_ok=True)  # the old set is no longer whole from here: see output_set
    final = []
    for path in written:
        existing_kind(folder / path.name, streams=False)  # InputError for a link or device in its place: not replaced
    for path in written:
        os.replace(path, folder / path.name)
        final.append(folder / path.name)
    return final


def finished_outputs(folder: Path, formats, digest: str | None = None) -> tuple[list[str] | None, str]:
    """(the outputs of a complete earlier run in ``folder`` with at least ``formats`` and, given ``digest``, the same
    fingerprint of inputs and settings, else None; why it is or is not finished)."""
    manifest = read_record(folder / MANIFEST, valid_manifest)  # a damaged one is moved aside with a warning
    if manifest is None:
        return None, f"no {MANIFEST} of a finished earlier run"
    names, done = manifest["outputs"], set(manifest["formats"])
    outputs = [str(folder / Path(n).name) for n in names]  # output-relative (older manifests: any path, same name)
    if not set(formats) <= done:
        return None, f"the earlier run wrote only {', '.join(sorted(done))}"
    if digest is not None and manifest.get("fingerprint") != digest:
        return None, "its inputs or settings changed since the earlier run"
    missing = [Path(p).name for p in outputs if not Path(p).is_file()]
    if missing:
        return None, f"output(s) {', '.join(missing)} of the earlier run are missing"
    changed = changed_files(folder, manifest.get("files"))
    if changed is None or not {Path(p).name for p in outputs} <= set(manifest["files"]):
        return None, f"its {MANIFEST} has no checksums of every output (an older version, or damaged)"
    if changed:
        return None, f"output(s) {', '.join(changed)} differ from what the earlier run wrote"
    return outputs, "finished earlier with the same inputs and settings"
