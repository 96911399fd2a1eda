"""One job of ``platypose lift``: views -> 2D tracks -> cameras -> root paths -> hypotheses -> files in OUT/<name>/.

Hypotheses are written into a staging folder as lifting hands frames out, files
are exported from there a chunk of frames at a time (memory does not grow with
the input's length) and moved into ``OUT/<name>/`` only when all of them are
written, then ``lift.json`` (the list of outputs) is written last: a job that
fails or is interrupted leaves earlier outputs as they were and no staging
folder, and ``--resume`` trusts only folders with a ``lift.json`` whose outputs exist
and whose fingerprint (input files' names, sizes and dates; every setting that shapes
the result) is the current one. Paths in ``lift.json`` are relative to its folder.
A failed run keeps an earlier good run's outputs and ``log.txt`` (its own log is
``log-failed.txt``); a transient failure (full disk, I/O error) is retried by
``--resume``. Staging folders carry their process ID, so a later run removes the
ones of killed runs.
"""

from __future__ import annotations

import errno
import glob
import hashlib
import json
import os
import shutil
import tempfile
import time
import traceback
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from platypose.cli.app import describe_os_error
from platypose.cli.bookkeeping import read_record, valid_failure, valid_manifest
from platypose.cli.detection import command_reader
from platypose.cli.input_stamps import input_stamp
from platypose.cli.lift_jobs import Job
from platypose.cli.locks import exclusive_lock
from platypose.cli.options import as_json, cli_message
from platypose.cli.output_names import FAILURE, MANIFEST, job_sources
from platypose.cli.output_set import changed_files, digests
from platypose.cli.progress_bars import GroupBars
from platypose.cli.split_pieces import remove_pieces
from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import existing_kind, write_text_atomic
from platypose.lifting.job_log import JobLog
from platypose.lifting.settings import DetectOptions, PriorSettings, TakeSettings

JOB_LOCK = ".lift.lock"  # in OUT/<name>/: held by the one run writing that folder
SYNC_FILE = "sync_offsets.json"  # offsets estimated by --sync auto, for reuse as --sync FILE


@dataclass(frozen=True)
class RunSettings:
    """Everything a job needs besides its views (picklable, for worker processes)."""

    out: Path
    cams: Path | None = None
    prior: PriorSettings = field(default_factory=PriorSettings)
    detect: DetectOptions = field(default_factory=DetectOptions)
    take: TakeSettings = field(default_factory=TakeSettings)
    formats: tuple[str, ...] = ("npz", "csv", "bvh", "rrd")
    quiet: bool = False
    arguments: dict = field(default_factory=dict)
    split_seconds: float | None = None  # --split-seconds: one input spread over pieces (platypose.cli.split_join)


_PRIORS: dict[PriorSettings, object] = {}


def _prior(settings: PriorSettings):
    """The prior of ``settings``, loaded once per process."""
    from platypose.lifting.prior.runtime import load_settings

    if settings not in _PRIORS:
        _PRIORS[settings] = load_settings(settings)
    return _PRIORS[settings]


def lift_job(job: Job, settings: RunSettings, log: JobLog, staging: Path, pieces=None):
    """The LiftResult of one job (:func:`platypose.pipeline.run_take`), its long arrays in files under
    ``staging``, and the videos of its cameras; offsets estimated by ``--sync auto`` are saved for reuse; with
    ``pieces``, spread over that pool (:func:`platypose.cli.split_join.split_hooks`)."""
    from platypose.exporters.frames import FrameArray
    from platypose.pipeline import run_take

    calibration = None
    if settings.cams is not None:
        from platypose.lifting.calibration import load_calibration

        calibration = load_calibration(settings.cams)
    read = command_reader(settings.detect, lambda _: settings.out / job.name, settings.quiet)
    lifter = None
    if pieces is not None:  # --split-seconds: detection and lifting spread over the pool
        from platypose.cli.split_join import split_hooks

        lifter, read = split_hooks(pieces, settings, job.name, log, read)
    bars = GroupBars(settings.quiet)
    try:
        result = run_take(
            views=[(v.name, v.source) for v in job.views],
            calibration=calibration,
            settings=settings.take,
            read=read,
            prior=lambda: _prior(settings.prior),
            log=log,
            what=job.input,
            described=str(settings.cams),
            cams_option="--cams",
            arguments=settings.arguments,
            arrays=lambda shape, name: FrameArray.create(staging / f".{name}.npy", shape, np.float32),
            progress=bars.update,
            lifter=lifter,
        )
    finally:
        bars.close()
    if "confidence" in result.meta["sync"]:
        write_text_atomic(settings.out / job.name / SYNC_FILE, json.dumps(result.meta["sync"], indent=1) + "\n")
    videos = {c.name: v.video for c, v in zip(result.cameras, job.views) if v.video is not None}
    return result, videos


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


def export_atomically(result, videos, staging: Path, folder: Path, name: str, formats, log: JobLog) -> list[Path]:
    """Export into ``staging``, then move every file written into ``folder``; returns the final paths."""
    from platypose.exporters import export

    written = export(result, staging, name, formats, videos, say=log, warn=log.warning)
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


def flag_lines(reports: list[dict]) -> list[str]:
    """The console's lines about a lift's flagged persons, from its plausibility ``reports`` (:func:`lifting.checks.flags.person_lines`)."""
    from platypose.lifting.checks.flags import person_lines

    return person_lines(reports, [report["track_id"] for report in reports])


def earlier_flags(folder: Path) -> list[str]:
    """The flag lines the finished earlier run in ``folder`` kept in its lift.json (none from older versions)."""
    flags = (read_record(folder / MANIFEST, valid_manifest) or {}).get("flags")
    return flags if isinstance(flags, list) and all(isinstance(line, str) for line in flags) else []


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


def write_failure(folder: Path, job: Job, error: str, digest: str, transient: bool) -> None:
    """Record a failed run of ``job`` in ``folder/failed.json``: its error, the fingerprint of its inputs and
    settings, and whether the failure was transient (retried by ``--resume``)."""
    failure = {"input": job.input, "sources": job_sources(job), "error": error, "fingerprint": digest}
    failure["transient"] = transient
    write_text_atomic(folder / FAILURE, json.dumps(failure, indent=1))


def earlier_failure(folder: Path, digest: str) -> str | None:
    """The error of an earlier failed run of the same input and settings in ``folder`` that was not transient
    (a full disk, an I/O error: worth retrying), else None."""
    failure = read_record(folder / FAILURE, valid_failure)  # a damaged one is moved aside with a warning
    if failure is None or failure["fingerprint"] != digest or failure.get("transient"):
        return None
    return failure["error"]


TRANSIENT_ERRNOS = frozenset(
    getattr(errno, name) for name in ("ENOSPC", "EDQUOT", "EIO", "EAGAIN", "EINTR", "ETIMEDOUT") if hasattr(errno, name)
)


def failure_kind(err: BaseException) -> str:
    """``input`` (bad input: exit 2), ``system`` (a file system or OS problem) or ``internal`` (a bug)."""
    if isinstance(err, InputError):
        return "input"
    return "system" if isinstance(err, OSError) else "internal"


def job_entry(
    job: Job, status: str, outputs: list[str] | None = None, seconds: float = 0.0, error: str | None = None
) -> dict:
    """A summary.json entry for ``job`` (a lifted one gains ``floor`` and ``plausibility``, as in its meta)."""
    return {
        "input": job.input,
        "name": job.name,
        "status": status,
        "outputs": outputs or [],
        "seconds": seconds,
        "error": error,
        "warnings": [],
    }


def run_job(job: Job, settings: RunSettings, pieces=None) -> dict:
    """Lift one job; its summary entry (status ok or failed, outputs, seconds, one-line error); with ``pieces``,
    spread over that pool (:mod:`platypose.cli.split_pieces`).

    The job's folder is locked for the run (``OUT/<name>/.lift.lock``): another run writing the same folder at that
    moment (another lift into the same --out) makes this one fail at once with nothing written, so the files of two
    runs are never mixed."""
    folder = settings.out / job.name
    busy = f"another platypose run is writing {folder}/ now; wait for it to end, or lift into another --out"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with exclusive_lock(folder / JOB_LOCK, wait=False, busy=busy):
            return _run_locked(job, settings, pieces)
    except (
        InputError,
        OSError,
    ) as err:  # the lock is held (locks.Busy), is not a lock file, or the folder cannot be made
        kind = "input" if isinstance(err, InputError) else "system"
        message = cli_message(err) if isinstance(err, InputError) else describe_os_error(err)
        return {**job_entry(job, "failed", error=message), "error_kind": kind}


def _run_locked(job: Job, settings: RunSettings, pieces=None) -> dict:
    """:func:`run_job` once the job's folder is locked."""
    started = time.perf_counter()
    log = JobLog()
    folder = settings.out / job.name
    log(f"input {job.input} -> {folder}")
    entry = job_entry(job, "failed")
    digest = fingerprint(job, settings)
    log_name = "log.txt"
    try:
        with staging_folder(folder, job.name) as staging:
            result, videos = lift_job(job, settings, log, staging, pieces)
            written = export_atomically(result, videos, staging, folder, job.name, settings.formats, log)
        stale = remove_stale_outputs(folder, job.name, written)
        if stale:
            log(f"removed output(s) of an earlier run that this run did not write: {', '.join(stale)}")
        outputs = [str(p) for p in written]
        manifest = {
            "input": job.input,
            "sources": job_sources(job),  # whose folder this is (output_names)
            "formats": list(settings.formats),
            "outputs": [p.name for p in written],  # relative to this folder
            "files": digests(written),
            "fingerprint": digest,
            "flags": flag_lines(result.meta["plausibility"]),  # said again when --resume skips this input
        }
        write_text_atomic(folder / MANIFEST, json.dumps(manifest, indent=1))
        (folder / FAILURE).unlink(missing_ok=True)
        remove_pieces(settings.out, job.name)  # a split lift's piece cache: done with
        entry.update(status="ok", outputs=outputs, floor=result.meta["floor"], plausibility=result.meta["plausibility"])
    except Exception as err:
        kind = failure_kind(err)
        if isinstance(err, InputError):
            message = cli_message(err)
        elif isinstance(err, OSError):
            message = describe_os_error(err)
        else:
            message = f"{type(err).__name__}: {err}"
        entry.update(error=" ".join(message.split()), error_kind=kind)
        log(f"failed: {entry['error']}")
        if kind == "internal":
            log(traceback.format_exc())
        transient = isinstance(err, OSError) and err.errno in TRANSIENT_ERRNOS
        write_failure(folder, job, entry["error"], digest, transient)
        if (folder / MANIFEST).is_file():
            log_name = "log-failed.txt"  # the good earlier run's outputs stay, and so does its log
    entry["warnings"] = list(log.warnings)
    entry["seconds"] = round(time.perf_counter() - started, 2)
    log(f"{entry['status']} in {entry['seconds']} s")
    log.write(folder / log_name)
    return entry
