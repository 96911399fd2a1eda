"""The end-to-end part of ``platypose bench``: a looped single-view clip lifted as ``platypose lift`` lifts it."""

from __future__ import annotations

import resource
import sys
import time
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from platypose.detectors.view_reader import ViewRead
from platypose.lifting.errors import InputError


def loop_video(source: Path, target: Path, frames: int, fps: float) -> tuple[int, int]:
    """Write ``frames`` frames of ``source``, looped from its start as often as needed, to ``target`` (mp4v at ``fps``).

    Returns the image size (height, width).
    """
    import cv2

    from platypose.detectors.sources.video import iter_frames, video_info

    height, width = video_info(source).image_size
    writer = cv2.VideoWriter(str(target), cv2.VideoWriter_fourcc(*"mp4v"), fps, (width, height))
    if not writer.isOpened():
        raise InputError(f"{target}: OpenCV cannot write an mp4v video here")
    written = 0
    try:
        while written < frames:
            before = written
            for _, frame in iter_frames(source, max_frames=frames - written):
                writer.write(frame)
                written += 1
            if written == before:
                raise InputError(f"{source}: no frames decoded")
    finally:
        writer.release()
    return height, width


def peak_rss_mb() -> float:
    """Peak resident memory of this process so far, in MiB (``ru_maxrss``: KiB on Linux, bytes on macOS)."""
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak / 2**20 if sys.platform == "darwin" else peak / 2**10


@dataclass(frozen=True)
class ClipTiming:
    """Seconds to detect a clip of ``frames`` frames (``tracks`` tracks found) and to lift ``persons`` of them,
    present in ``person_frames`` frames together (wall clock, and CPU seconds of the process: on a shared machine
    the two differ); peak memory after detection and after lifting; each phase's start and end (seconds from the
    start, :data:`PHASES` in order, the floor's quick lift only where it ran)."""

    frames: int
    tracks: int
    persons: int
    person_frames: int
    detect_s: float
    lift_s: float
    detect_cpu_s: float
    lift_cpu_s: float
    detect_peak_rss_mb: float
    peak_rss_mb: float
    phases: dict[str, tuple[float, float]]


PHASES = ("detection", "floor quick lift", "lift", "finishing")


@dataclass
class _Seen:
    """What :func:`lift_clip` measures around the pipeline's phases."""

    view: ViewRead | None = None
    detect_cpu_s: float = 0.0
    detect_peak_rss_mb: float = 0.0
    lift_cpu_started: float = 0.0


def lift_clip(
    video: Path, prior, samples: int, threads: int | None, say: Callable[[str], None], persons: str = "largest"
) -> ClipTiming:
    """Lift ``video`` as ``platypose lift`` lifts one view without ``--cams`` (:func:`platypose.pipeline.run_take`:
    the bundled MoveNet's tracks, the ``persons`` choice (largest, all or a count, as ``--persons``), the floor
    estimated under a quick lift, the lift with ``samples`` hypotheses of each person where present, and every
    finishing step), timed by phase.

    Wall seconds are the pipeline's own (``meta["timings"]``); CPU seconds and peak memory are taken around its
    phases: detection (the detector freed after it), then lifting from the prior's loading to the end.
    """
    from platypose.detectors.view_reader import ViewReader
    from platypose.lifting.job_log import JobLog
    from platypose.lifting.settings import DetectOptions, SamplerConfig, TakeSettings
    from platypose.lifting.tracks.quick_floor import QUICK_LIFT
    from platypose.lifting.tracks.roots import presence
    from platypose.pipeline import run_take

    take = TakeSettings(persons=persons, sampler=SamplerConfig(samples=samples))
    reader = ViewReader(DetectOptions(threads=threads), progress=lambda source, total: _said(100, "detected", say))
    began = time.perf_counter()
    at: dict[str, float] = {}  # when each step was last seen at work, seconds from the start
    seen = _Seen()

    def clock() -> float:
        return time.perf_counter() - began

    def read(source: Path) -> ViewRead:
        at["detection started"], cpu_started = clock(), time.process_time()
        view = reader(source)
        reader.model = None  # idle onnxruntime threads would slow torch down
        at["detection"] = clock()
        seen.view, seen.detect_cpu_s, seen.detect_peak_rss_mb = view, time.process_time() - cpu_started, peak_rss_mb()
        if view.tracks.num_persons == 0:
            raise InputError(f"{video}: no person detected")
        say(f"{view.tracks.num_frames} frames, {view.tracks.num_persons} track(s) in {view.seconds:.1f} s")
        return view

    def load_prior():
        at["lifting started"], seen.lift_cpu_started = clock(), time.process_time()
        return prior

    def progress(group: list[int] | str, done: int, total: int) -> None:
        phase = "floor quick lift" if group == QUICK_LIFT else "lift"
        at[phase] = clock()
        if done % 5 == 0 or done == total:
            say(f"  {done}/{total} windows lifted ({phase})")

    result = run_take(
        views=[("bench", video)],
        calibration=None,
        settings=take,
        read=read,
        prior=load_prior,
        log=JobLog(),
        what=str(video),
        progress=progress,
    )
    lift_cpu_s = time.process_time() - seen.lift_cpu_started
    at["finishing"] = clock()
    keypoints = np.moveaxis(np.asarray(result.keypoints2d), 1, 2)  # (C, T, P, 17, 3)
    person_frames = int(presence(keypoints, result.frame_times, take.windows.max_gap).sum())
    timings, tracks = result.meta["timings"], seen.view.tracks
    say(f"lifted {len(result.track_ids)} ({persons}), present in {person_frames} person-frames")
    return ClipTiming(
        frames=tracks.num_frames,
        tracks=tracks.num_persons,
        persons=len(result.track_ids),
        person_frames=person_frames,
        detect_s=timings["keypoints_s"],
        lift_s=timings["lift_s"],
        detect_cpu_s=seen.detect_cpu_s,
        lift_cpu_s=lift_cpu_s,
        detect_peak_rss_mb=seen.detect_peak_rss_mb,
        peak_rss_mb=peak_rss_mb(),
        phases=phase_spans(at),
    )


def phase_spans(at: dict[str, float]) -> dict[str, tuple[float, float]]:
    """Each phase's (start, end) in seconds from ``at``, the times steps were last seen at work: detection from its
    start to its end; the floor's quick lift (where it ran) from the lifting's start to its last window; the lift
    from there to its last window; finishing from there to the end."""
    spans = {"detection": (at["detection started"], at["detection"])}
    start = at["lifting started"]
    for phase in PHASES[1:]:
        if phase in at:
            spans[phase], start = (start, at[phase]), at[phase]
    return spans


def _said(step: int, what: str, say: Callable[[str], None]) -> AbstractContextManager[Callable[[int, int], None]]:
    """:func:`_every` as the context a :class:`~platypose.detectors.view_reader.ViewReader` counts frames in."""
    return nullcontext(_every(step, what, say))


def _every(step: int, what: str, say: Callable[[str], None]) -> Callable[[int, int], None]:
    """A ``progress(done, total)`` callback saying ``done/total what`` every ``step`` and at the end."""

    def progress(done: int, total: int) -> None:
        if done % step == 0 or done == total:
            say(f"  {done}/{total} {what}")

    return progress
