"""One job of ``platypose lift``: views -> 2D tracks -> cameras -> root paths -> hypotheses -> files in OUT/<name>/.

Hypotheses are written into a staging folder as lifting hands frames out, files
are exported from there a chunk of frames at a time (memory does not grow with
the input's length) and moved into ``OUT/<name>/`` only when all of them are
written, then ``lift.json`` (the list of outputs) is written last: a job that
fails or is interrupted leaves earlier outputs as they were and no staging
folder, and ``--resume`` trusts only folders with a ``lift.json`` whose outputs exist.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import sys
import tempfile
import time
import traceback
from collections.abc import Iterator
from contextlib import contextmanager
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
import typer

from platypose.cli.detection import Detection, DetectOptions
from platypose.cli.lift_jobs import Job
from platypose.cli.options import as_json, cli_message
from platypose.lifting.errors import InputError
from platypose.lifting.lift import WindowSettings
from platypose.lifting.runtime import PriorSettings
from platypose.lifting.sampler import SamplerConfig

MANIFEST = "lift.json"
FAILURE = "failed.json"
SIZE_TOLERANCE = 0.02  # calibrated vs actual image size: relative difference accepted with a warning


@dataclass(frozen=True)
class RunSettings:
    """Everything a job needs besides its views (picklable, for worker processes)."""

    out: Path
    cams: Path | None = None
    prior: PriorSettings = field(default_factory=PriorSettings)
    detect: DetectOptions = field(default_factory=DetectOptions)
    sampler: SamplerConfig = field(default_factory=SamplerConfig)
    windows: WindowSettings = field(default_factory=WindowSettings)
    formats: tuple[str, ...] = ("npz", "csv", "bvh", "rrd")
    persons: str = "all"
    root: str = "auto"
    root_file: Path | None = None
    quiet: bool = False
    arguments: dict = field(default_factory=dict)


class JobLog:
    """Timestamped lines for ``OUT/<name>/log.txt``, kept in memory and written atomically at the end."""

    def __init__(self) -> None:
        self.started = time.perf_counter()
        self.lines: list[str] = []
        self.warnings: list[str] = []

    def __call__(self, message: str) -> None:
        self.lines.append(f"[{time.perf_counter() - self.started:7.1f} s] {message}")

    def warning(self, message: str) -> None:
        """Log a warning and keep it for the result's meta."""
        self.warnings.append(message)
        self(f"warning: {message}")

    def write(self, path: Path) -> None:
        """Write the log atomically."""
        from platypose.lifting.atomic import write_text_atomic

        write_text_atomic(path, "\n".join(self.lines) + "\n")


_PRIORS: dict[PriorSettings, object] = {}


def _prior(settings: PriorSettings):
    """The prior of ``settings``, loaded once per process."""
    if settings not in _PRIORS:
        _PRIORS[settings] = settings.load()
    return _PRIORS[settings]


def _check_size(camera, image_size: tuple[int, int], source: str, log: JobLog) -> None:
    """Warn about a small calibrated/actual image size difference; InputError for a large one."""
    if tuple(camera.size) == tuple(image_size):
        return
    relative = max(abs(a - b) / b for a, b in zip(camera.size, image_size))
    said = (
        f"calibration says {camera.width}x{camera.height} px for camera {camera.name}, "
        f"{source} is {image_size[1]}x{image_size[0]}"
    )
    if relative > SIZE_TOLERANCE:
        raise InputError(f"{source}: calibration mismatch: {said}")
    log.warning(f"{said}; pixels used as they are (the principal point is what matters)")


def calibrated_cameras(job: Job, cams: Path) -> list:
    """The camera of ``cams`` matching each view by name; InputError (calibration mismatch) when one has none."""
    from platypose.lifting.calibration import load_calibration
    from platypose.lifting.calibration.matching import match_views

    calibration = load_calibration(cams)
    try:
        pairs = match_views(calibration.names, [v.name for v in job.views], allow_missing=True)
    except InputError as err:
        raise InputError(f"{job.input}: calibration mismatch with {cams}: {err}") from None
    by_view = {view: calibration.camera(camera) for camera, view in pairs.items()}
    return [by_view[v.name] for v in job.views]


def view_cameras(job: Job, views, calibrated: list | None, log: JobLog) -> list:
    """The calibrated cameras checked against the views' image sizes, or the default camera of a single view."""
    if calibrated is not None:
        for camera, tracks, view in zip(calibrated, views, job.views):
            _check_size(camera, tracks.image_size, str(view.source), log)
        return calibrated
    if len(views) > 1:
        raise InputError(f"{job.input}: {len(views)} views need --cams to place the cameras")
    from platypose.lifting.calibration.defaults import default_camera

    log.warning("no --cams: a level camera at the origin with a 53 degree diagonal field of view is assumed")
    return [default_camera(job.views[0].name, *views[0].image_size)]


def root_paths(keypoints, times, cameras, settings: RunSettings, log: JobLog) -> list[np.ndarray | None]:
    """Per person: the pelvis path of ``--root-trajectory`` (T, 3), a triangulated one, or None (solved)."""
    from platypose.lifting.take import root_paths as decide_roots

    given = None
    if settings.root_file is not None:
        from platypose.cli.root_file import read_root_trajectory

        log(f"root trajectory from {settings.root_file}")
        given = list(read_root_trajectory(settings.root_file, times, keypoints.shape[2]))
    return decide_roots(keypoints, times, cameras, settings.root, given, say=log)


def lift_keypoints(prior, keypoints, times, cameras, roots, absent, settings: RunSettings, folder: Path):
    """Hypotheses (P, N, T, 17, 3), their median (P, T, 17, 3) and energy (P, N, T) as FrameArrays in ``folder``,
    filled by :func:`platypose.lifting.take.lift_persons` with a progress bar per group of persons."""
    from platypose.exporters.frames import FrameArray
    from platypose.lifting.take import lift_persons

    (P, T), N = absent.shape, settings.sampler.samples
    hypotheses = FrameArray.create(folder / ".hypotheses.npy", (P, N, T, 17, 3), np.float32)
    median = FrameArray.create(folder / ".median.npy", (P, T, 17, 3), np.float32)
    energy = FrameArray.create(folder / ".energy.npy", (P, N, T), np.float32)
    bars = _GroupBars(settings.quiet)
    try:
        lift_persons(
            prior,
            keypoints,
            times,
            cameras,
            roots,
            absent,
            settings.sampler,
            settings.windows,
            hypotheses,
            median,
            energy,
            bars.update,
        )
    finally:
        bars.close()
    return hypotheses, median, energy


class _GroupBars:
    """One progress bar per group of persons lifted together, its length known at its first update."""

    def __init__(self, hidden: bool) -> None:
        self.hidden, self.group, self.bar = hidden, None, None

    def update(self, group: list[int], done: int, total: int) -> None:
        if group != self.group:
            self.close()
            self.group, self.bar = group, _LazyBar(f"lifting {len(group)} person(s)", self.hidden)
        self.bar.update(done, total)

    def close(self) -> None:
        """Finish the current bar's line."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None


class _LazyBar:
    """A progress bar whose length is known only at the first ``update(done, total)``."""

    def __init__(self, label: str, hidden: bool) -> None:
        self.label, self.hidden, self.bar, self.done = label, hidden, None, 0

    def update(self, done: int, total: int) -> None:
        if self.bar is None:
            self.bar = typer.progressbar(length=total, label=self.label, file=sys.stderr, hidden=self.hidden)
            self.bar.__enter__()
        self.bar.update(done - self.done)
        self.done = done

    def close(self) -> None:
        """Finish the bar's line, if it was shown."""
        if self.bar is not None:
            self.bar.__exit__(None, None, None)


def report_reprojection(median, keypoints: np.ndarray, cameras: list, log: JobLog) -> dict[str, float]:
    """:func:`platypose.lifting.take.reprojection_report` logged: one line of per-view pixels, its warnings."""
    from platypose.lifting.take import reprojection_report

    report, warnings = reprojection_report(median, keypoints, cameras)
    if report:
        log(
            "median motion against the keypoints (median px per view): "
            + ", ".join(f"{name} {value:.1f}" for name, value in report.items())
        )
    for warning in warnings:
        log.warning(warning)
    return report


def lift_job(job: Job, settings: RunSettings, log: JobLog, staging: Path):
    """The LiftResult of one job, its long arrays in files under ``staging``, and the videos of its cameras."""
    from platypose import __version__
    from platypose.detectors.take import take_keypoints
    from platypose.exporters.result import LiftResult
    from platypose.lifting.root import presence

    timings: dict[str, float] = {}
    started = time.perf_counter()
    calibrated = calibrated_cameras(job, settings.cams) if settings.cams is not None else None
    detection = Detection(settings.detect)
    views = []
    for view in job.views:
        tracks, seconds, frames = detection.tracks(view.source, settings.out / job.name, settings.quiet)
        how = "read" if frames is None else ("from the cache" if frames == 0 else f"detected in {frames} frames")
        log(
            f"view {view.name}: {view.source} -> {tracks.num_frames} frames, {tracks.num_persons} track(s), "
            f"{how}, {seconds:.1f} s"
        )
        views.append(tracks)
    timings["keypoints_s"] = time.perf_counter() - started
    cameras = view_cameras(job, views, calibrated, log)
    keypoints, times, track_ids = take_keypoints(views, cameras, settings.persons, job.input)
    log(f"{keypoints.shape[0]} view(s), {len(times)} frames, {len(track_ids)} person(s) (--persons {settings.persons})")
    roots = root_paths(keypoints, times, cameras, settings, log)
    prior = _prior(settings.prior)
    started = time.perf_counter()
    absent = ~presence(keypoints, times)  # (P, T)
    hypotheses, median, energy = lift_keypoints(prior, keypoints, times, cameras, roots, absent, settings, staging)
    timings["lift_s"] = time.perf_counter() - started
    log(f"lifted {hypotheses.shape[1]} hypotheses in {timings['lift_s']:.1f} s")
    reprojection = report_reprojection(median, keypoints, cameras, log)
    fps = 1.0 / float(np.median(np.diff(times))) if len(times) > 1 else prior.fps
    meta = {
        "version": __version__,
        "input": job.input,
        "arguments": settings.arguments,
        "prior_sha256": prior.checksum,
        "root": ["given" if settings.root_file else ("solved" if r is None else "triangulated") for r in roots],
        "timings": timings,
        "reprojection_px": reprojection,
        "warnings": log.warnings,
    }
    result = LiftResult(
        hypotheses=hypotheses,
        median=median,
        keypoints2d=np.moveaxis(keypoints, 2, 1),
        frame_times=times,
        fps=fps,
        track_ids=track_ids,
        cameras=tuple(cameras),
        energy=energy,
        meta=meta,
    )
    videos = {c.name: v.video for c, v in zip(cameras, job.views) if v.video is not None}
    return result, videos


@contextmanager
def staging_folder(folder: Path, name: str) -> Iterator[Path]:
    """A new staging folder beside ``folder`` (created if needed), removed with whatever is left in it at the end."""
    folder.mkdir(parents=True, exist_ok=True)
    staging = Path(tempfile.mkdtemp(prefix=f".{name}.", suffix=".partial", dir=folder.parent))
    try:
        yield staging
    finally:
        shutil.rmtree(staging, ignore_errors=True)


def export_atomically(result, videos, staging: Path, folder: Path, name: str, formats, log: JobLog) -> list[Path]:
    """Export into ``staging``, then move every file written into ``folder``; returns the final paths."""
    from platypose.exporters import export

    written = export(result, staging, name, formats, videos, say=log)
    final = []
    for path in written:
        os.replace(path, folder / path.name)
        final.append(folder / path.name)
    return final


def finished_outputs(folder: Path, formats) -> list[str] | None:
    """The outputs listed by a complete earlier run in ``folder`` with at least ``formats``, else None."""
    try:
        manifest = json.loads((folder / MANIFEST).read_text(encoding="utf-8"))
        outputs, done = list(manifest["outputs"]), set(manifest["formats"])
    except (OSError, ValueError, KeyError, TypeError):
        return None
    complete = set(formats) <= done and all(Path(p).is_file() for p in outputs)
    return outputs if complete else None


def _stamp(path: Path) -> list:
    """What identifies a file's or folder's content cheaply: path, size (or entry count) and latest change."""
    if path.is_dir():
        entries = list(path.iterdir())
        return [str(path), len(entries), max((e.stat().st_mtime_ns for e in entries), default=0)]
    stat = path.stat() if path.exists() else None
    return [str(path), stat.st_size if stat else None, stat.st_mtime_ns if stat else None]


def fingerprint(job: Job, settings: RunSettings) -> str:
    """A digest of the job's input files and the settings that decide whether it can succeed."""
    files = [v.source for v in job.views] + [p for p in (settings.cams, settings.root_file, settings.prior.path) if p]
    decisive = [
        str(replace(settings.detect, threads=None)),
        settings.persons,
        settings.root,
        as_json(settings.sampler),
        as_json(settings.windows),
        [_stamp(Path(f)) for f in files],
    ]
    return hashlib.sha256(json.dumps(decisive, sort_keys=True, default=str).encode()).hexdigest()


def earlier_failure(folder: Path, digest: str) -> str | None:
    """The error of an earlier failed run of the same input and settings in ``folder``, else None."""
    try:
        failure = json.loads((folder / FAILURE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return None
    return failure.get("error") if isinstance(failure, dict) and failure.get("fingerprint") == digest else None


def job_entry(
    job: Job, status: str, outputs: list[str] | None = None, seconds: float = 0.0, error: str | None = None
) -> dict:
    """A summary.json entry for ``job``."""
    return {
        "input": job.input,
        "name": job.name,
        "status": status,
        "outputs": outputs or [],
        "seconds": seconds,
        "error": error,
    }


def run_job(job: Job, settings: RunSettings) -> dict:
    """Lift one job; its summary entry (status ok or failed, outputs, seconds, one-line error)."""
    from platypose.lifting.atomic import write_text_atomic

    started = time.perf_counter()
    log = JobLog()
    folder = settings.out / job.name
    log(f"input {job.input} -> {folder}")
    entry = job_entry(job, "failed")
    try:
        with staging_folder(folder, job.name) as staging:
            result, videos = lift_job(job, settings, log, staging)
            written = export_atomically(result, videos, staging, folder, job.name, settings.formats, log)
        outputs = [str(p) for p in written]
        manifest = {"input": job.input, "formats": list(settings.formats), "outputs": outputs}
        write_text_atomic(folder / MANIFEST, json.dumps(manifest, indent=1))
        (folder / FAILURE).unlink(missing_ok=True)
        entry.update(status="ok", outputs=outputs)
    except Exception as err:
        message = cli_message(err) if isinstance(err, InputError) else f"{type(err).__name__}: {err}"
        entry["error"] = " ".join(message.split())
        log(f"failed: {entry['error']}")
        if not isinstance(err, InputError):
            log(traceback.format_exc())
        failure = {"input": job.input, "error": entry["error"], "fingerprint": fingerprint(job, settings)}
        write_text_atomic(folder / FAILURE, json.dumps(failure, indent=1))
    entry["seconds"] = round(time.perf_counter() - started, 2)
    log(f"{entry['status']} in {entry['seconds']} s")
    log.write(folder / "log.txt")
    return entry
