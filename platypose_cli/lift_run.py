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
from platypose.lifting.errors import InputError

MANIFEST = "lift.json"
FAILURE = "failed.json"
ROOT_MODES = ("auto", "triangulate", "solve")
SIZE_TOLERANCE = 0.02  # calibrated vs actual image size: relative difference accepted with a warning


@dataclass(frozen=True)
class RunSettings:
    """Everything a job needs besides its views (picklable, for worker processes)."""

    out: Path
    cams: Path | None = None
    prior: Path | None = None
    detect: DetectOptions = field(default_factory=DetectOptions)
    sampler: dict = field(default_factory=dict)
    window: int = 64
    overlap: int = 16
    formats: tuple[str, ...] = ("npz", "csv", "bvh", "rrd")
    persons: str = "all"
    root: str = "auto"
    root_file: Path | None = None
    quiet: bool = False
    arguments: dict = field(default_factory=dict)
    device: str = "cpu"


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


_PRIORS: dict[str, object] = {}


def _prior(path: Path | None, device: str = "cpu"):
    """The prior at ``path`` (default: the shipped one) on ``device``, loaded once per process."""
    from platypose.lifting.runtime import load_for_runtime

    key = f"{path}@{device}"
    if key not in _PRIORS:
        _PRIORS[key] = load_for_runtime(path, device)
    return _PRIORS[key]


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


def gather_keypoints(job: Job, views, cameras, persons: str):
    """Keypoints (C, T, P, 17, 3) of the chosen persons on the first view's clock, frame times (T,), track IDs (P,)."""
    from platypose.detectors.tracking import persons_to_keep
    from platypose.lifting.calibration.matching import gather_views

    if len(views) > 1:
        from platypose.detectors.multiview import match_across_views

        views = match_across_views(views, cameras)
    keep = persons_to_keep(views, persons)
    views = views if keep is None else [v.select(keep) for v in views]
    if views[0].num_persons == 0:
        raise InputError(f"{job.input}: no person found")
    step = np.median(np.diff(views[0].frame_times)) if views[0].num_frames > 1 else 1.0
    gathered = gather_views([v.keypoints for v in views], [v.frame_times for v in views], cameras, 0.5 * step)
    return np.stack(gathered), views[0].frame_times, views[0].track_ids


def root_paths(keypoints, times, cameras, settings: RunSettings, log: JobLog) -> list[np.ndarray | None]:
    """Per person: a known root path (T, 3) (file or triangulation), or None to solve it per hypothesis."""
    from platypose.lifting.root import fill_gaps, triangulated_root

    P = keypoints.shape[2]
    if settings.root_file is not None:
        from platypose.cli.root_file import read_root_trajectory

        log(f"root trajectory from {settings.root_file}")
        return list(read_root_trajectory(settings.root_file, times, P))
    if settings.root == "solve" or (settings.root == "auto" and len(cameras) < 2):
        log("root: solved per hypothesis from the rays of every camera")
        return [None] * P
    if len(cameras) < 2:
        raise InputError(f"--root triangulate needs two or more calibrated views, got {len(cameras)}")
    roots = triangulated_root(keypoints, cameras)
    paths: list[np.ndarray | None] = []
    for p in range(P):
        covered = np.isfinite(roots[p]).all(-1).mean()
        usable = covered >= 0.5
        log(
            f"root of person {p}: pelvis triangulated in {covered:.0%} of frames; "
            + ("gaps interpolated" if usable else "too few, solved per hypothesis instead")
        )
        paths.append(fill_gaps(roots[p], times) if usable else None)
    return paths


def lift_keypoints(prior, keypoints, times, cameras, roots, absent, settings: RunSettings, folder: Path):
    """Hypotheses (P, N, T, 17, 3), their median (P, T, 17, 3) and energy (P, N, T) as FrameArrays in ``folder``.

    Persons with a known root and the others are lifted apart; frames are written as
    lifting hands them out, with NaN where ``absent`` (P, T), so memory stays bounded.
    """
    from platypose.cli.options import sampler_config
    from platypose.exporters.frames import FrameArray
    from platypose.lifting.lift import WindowSettings, lift_stream

    config = sampler_config(**settings.sampler)
    windows = WindowSettings(window=settings.window, overlap=settings.overlap)
    (P, T), N = absent.shape, config.samples
    hypotheses = FrameArray.create(folder / ".hypotheses.npy", (P, N, T, 17, 3), np.float32)
    median = FrameArray.create(folder / ".median.npy", (P, T, 17, 3), np.float32)
    energy = FrameArray.create(folder / ".energy.npy", (P, N, T), np.float32)
    known = [p for p in range(P) if roots[p] is not None]
    groups = [(g, root) for g, root in ((known, True), ([p for p in range(P) if roots[p] is None], False)) if g]
    for group, has_root in groups:
        root = np.stack([roots[p] for p in group]) if has_root else None
        bar = _LazyBar(f"lifting {len(group)} person(s)", settings.quiet)
        try:
            for chunk in lift_stream(prior, cameras, keypoints[:, :, group], times, config, windows, root, bar.update):
                t = slice(chunk.start, chunk.start + chunk.hypotheses.shape[2])
                gone = absent[group, t][:, None]  # (G, 1, t)
                chunk.hypotheses[np.broadcast_to(gone, chunk.hypotheses.shape[:3])] = np.nan
                chunk.energy[np.broadcast_to(gone, chunk.energy.shape)] = np.nan
                hypotheses[group, :, t] = chunk.hypotheses
                energy[group, :, t] = chunk.energy
                median[group, t] = np.median(chunk.hypotheses, axis=1)
        finally:
            bar.close()
    return hypotheses, median, energy


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


REPROJECTION_WARNING_SHARE = (
    0.02  # of the image width: a view whose keypoints the median motion misses by more is suspect
)


def report_reprojection(median, keypoints: np.ndarray, cameras: list, log: JobLog) -> dict[str, float]:
    """Per view, the median pixel distance between the median motion ``(P, T, 17, 3)`` and the view's keypoints
    ``(C, T, P, 17, 3)`` (the largest over persons), logged; views above ``REPROJECTION_WARNING_SHARE`` of their
    image width get a warning.

    With one view guidance fits the keypoints exactly and nothing is reported. With several, a view far off
    the others usually has a wrong calibration (or a detector that lost the person there).
    """
    from platypose.lifting.triangulation import view_median_errors

    if len(cameras) < 2:
        return {}
    per_person = [view_median_errors(median[p], keypoints[:, :, p], cameras) for p in range(keypoints.shape[2])]
    errors = np.nanmax(np.stack(per_person), axis=0) if per_person else np.full(len(cameras), np.nan)
    report = {cam.name: round(float(e), 2) for cam, e in zip(cameras, errors)}
    log(
        "median motion against the keypoints (median px per view): "
        + ", ".join(f"{name} {value:.1f}" for name, value in report.items())
    )
    for cam, value in zip(cameras, report.values()):
        if value > REPROJECTION_WARNING_SHARE * cam.width:
            log.warning(
                f"view {cam.name}: the median motion lies {value:.1f} px (median) from its keypoints, "
                f"{value / cam.width:.0%} of the image width; check its calibration and its detections"
            )
    return report


def lift_job(job: Job, settings: RunSettings, log: JobLog, staging: Path):
    """The LiftResult of one job, its long arrays in files under ``staging``, and the videos of its cameras."""
    from platypose import __version__
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
    keypoints, times, track_ids = gather_keypoints(job, views, cameras, settings.persons)
    log(f"{keypoints.shape[0]} view(s), {len(times)} frames, {len(track_ids)} person(s) (--persons {settings.persons})")
    roots = root_paths(keypoints, times, cameras, settings, log)
    prior = _prior(settings.prior, settings.device)
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
    files = [v.source for v in job.views] + [p for p in (settings.cams, settings.root_file, settings.prior) if p]
    decisive = [
        str(replace(settings.detect, threads=None)),
        settings.persons,
        settings.root,
        settings.sampler,
        settings.window,
        settings.overlap,
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
        message = str(err) if isinstance(err, InputError) else f"{type(err).__name__}: {err}"
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
