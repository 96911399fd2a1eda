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
import json
import time
import traceback
from collections.abc import Callable
from pathlib import Path

import numpy as np

from platypose.cli.runs.fingerprint import fingerprint
from platypose.cli.runs.jobs import Job, job_sources
from platypose.cli.runs.locks import exclusive_lock
from platypose.cli.runs.models import command_reader, loaded_prior
from platypose.cli.runs.outputs import digests, export_atomically, remove_stale_outputs, staging_folder
from platypose.cli.runs.pieces import remove_pieces
from platypose.cli.runs.playable import PlayableCopies
from platypose.cli.runs.records import FAILURE, MANIFEST, flag_lines, write_failure
from platypose.cli.runs.settings import RunSettings
from platypose.cli.terminal.console import describe_os_error
from platypose.cli.terminal.options import cli_message
from platypose.cli.terminal.progress_bars import GroupBars
from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import write_text_atomic
from platypose.lifting.job_log import JobLog

JOB_LOCK = ".lift.lock"  # in OUT/<name>/: held by the one run writing that folder
SYNC_FILE = "sync_offsets.json"  # offsets estimated by --sync auto, for reuse as --sync FILE
Hooks = Callable[[str, JobLog, Callable], tuple[Callable, Callable]]  # (name, log, reader) -> (lifter, reader)


def lift_job(job: Job, settings: RunSettings, log: JobLog, staging: Path, hooks: Hooks | None = None):
    """The LiftResult of one job (:func:`platypose.pipeline.run_take`), its long arrays in files under
    ``staging``, and the videos of its cameras; offsets estimated by ``--sync auto`` are saved for reuse. ``hooks``,
    an executor's: ``hooks(name, log, read)`` gives the lifter and view reader to use instead of this process's
    (``--split-seconds``: :func:`platypose.cli.runs.split.split_hooks`, the take spread over a pool of pieces)."""
    from platypose.exporters.frames import FrameArray
    from platypose.pipeline import run_take

    calibration = None
    if settings.cams is not None:
        from platypose.lifting.calibration import load_calibration

        calibration = load_calibration(settings.cams)
    read = command_reader(settings.detect, lambda _: settings.out / job.name, settings.quiet)
    lifter = None
    if hooks is not None:
        lifter, read = hooks(job.name, log, read)
    bars = GroupBars(settings.quiet)
    try:
        result = run_take(
            views=[(v.name, v.source) for v in job.views],
            calibration=calibration,
            settings=settings.take,
            read=read,
            prior=lambda: loaded_prior(settings.prior),
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


def playable_copies(job: Job, settings: RunSettings, staging: Path, log: JobLog) -> PlayableCopies:
    """The job's videos made playable for its recording in ``staging``, re-encoding beside the lift where rerun
    cannot play them; none without ``--formats rrd``."""
    copies = PlayableCopies([v.video for v in job.views] if "rrd" in settings.formats else [], staging)
    for video in copies.reencoding:
        log(f"re-encoding {video.name} to H.264 for rerun, beside the lift")
    return copies


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


def run_job(job: Job, settings: RunSettings, hooks: Hooks | None = None) -> dict:
    """Lift one job; its summary entry (status ok or failed, outputs, seconds, one-line error); ``hooks``: the
    executor's lifter and view reader (:func:`lift_job`).

    The job's folder is locked for the run (``OUT/<name>/.lift.lock``): another run writing the same folder at that
    moment (another lift into the same --out) makes this one fail at once with nothing written, so the files of two
    runs are never mixed."""
    folder = settings.out / job.name
    busy = f"another platypose run is writing {folder}/ now; wait for it to end, or lift into another --out"
    try:
        folder.mkdir(parents=True, exist_ok=True)
        with exclusive_lock(folder / JOB_LOCK, wait=False, busy=busy):
            return _run_locked(job, settings, hooks)
    except (
        InputError,
        OSError,
    ) as err:  # the lock is held (locks.Busy), is not a lock file, or the folder cannot be made
        kind = "input" if isinstance(err, InputError) else "system"
        message = cli_message(err) if isinstance(err, InputError) else describe_os_error(err)
        return {**job_entry(job, "failed", error=message), "error_kind": kind}


def _run_locked(job: Job, settings: RunSettings, hooks: Hooks | None) -> dict:
    """:func:`run_job` once the job's folder is locked."""
    started = time.perf_counter()
    log = JobLog()
    folder = settings.out / job.name
    log(f"input {job.input} -> {folder}")
    entry = job_entry(job, "failed")
    digest = fingerprint(job, settings)
    log_name = "log.txt"
    try:
        with staging_folder(folder, job.name) as staging, playable_copies(job, settings, staging, log) as copies:
            result, videos = lift_job(job, settings, log, staging, hooks)
            playable = {c.name: p for c, p in zip(result.cameras, copies.paths()) if p is not None}
            if playable:
                seconds = f"{copies.seconds:.1f} s"
                log(f"camera(s) {', '.join(playable)}: video re-encoded for rerun beside the lift in {seconds}")
            written = export_atomically(
                result, videos, staging, folder, job.name, settings.formats, log, playable=playable
            )
        stale = remove_stale_outputs(folder, job.name, written)
        if stale:
            log(f"removed output(s) of an earlier run that this run did not write: {', '.join(stale)}")
        outputs = [str(p) for p in written]
        manifest = {
            "input": job.input,
            "sources": job_sources(job),  # whose folder this is (runs/folders.py)
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
