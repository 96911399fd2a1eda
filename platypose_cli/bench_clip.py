"""The end-to-end part of ``platypose bench``: a looped single-view clip, detected with MoveNet and lifted."""

from __future__ import annotations

import resource
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

from platypose.lifting.errors import InputError


def loop_video(source: Path, target: Path, frames: int, fps: float) -> tuple[int, int]:
    """Write ``frames`` frames of ``source``, looped from its start as often as needed, to ``target`` (mp4v at ``fps``).

    Returns the image size (height, width).
    """
    import cv2

    from platypose.detectors.video import iter_frames, video_info

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
    the two differ); peak memory after detection and after lifting."""

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


def lift_clip(
    video: Path, prior, samples: int, threads: int | None, say: Callable[[str], None], persons: str = "largest"
) -> ClipTiming:
    """Detect people in ``video`` with the bundled MoveNet, then lift the tracks ``persons`` selects (as
    ``--persons``: largest, all or a count) with ``samples`` hypotheses.

    Each person is lifted where it is present (a looped clip starts new tracks at
    its seams). The view has the default camera (no calibration), like ``platypose
    lift`` without ``--cams``.
    """
    from platypose.detectors.contracts import load_detector
    from platypose.detectors.pipeline import detect_video
    from platypose.detectors.tracking import select_persons
    from platypose.lifting.calibration.defaults import default_camera
    from platypose.lifting.settings import SamplerConfig
    from platypose.lifting.tracks.roots import presence
    from platypose.lifting.tracks.stream import lift_tracks

    started, cpu_started = time.perf_counter(), time.process_time()
    detector = load_detector(threads=threads)
    tracks = detect_video(video, detector, progress=_every(100, "detected", say))
    del detector  # idle onnxruntime threads would slow torch down
    detect_s, detect_cpu_s = time.perf_counter() - started, time.process_time() - cpu_started
    detect_peak = peak_rss_mb()
    if tracks.num_persons == 0:
        raise InputError(f"{video}: no person detected")
    chosen = select_persons(tracks, persons)
    keypoints = chosen.keypoints[None]  # (C=1, T, P, 17, 3)
    person_frames = int(presence(keypoints, chosen.frame_times).sum())
    say(
        f"{tracks.num_frames} frames, {tracks.num_persons} track(s) in {detect_s:.1f} s; lifting {chosen.num_persons}"
        f" ({persons}), present in {person_frames} person-frames"
    )
    camera = default_camera("bench", *tracks.image_size)
    started, cpu_started = time.perf_counter(), time.process_time()
    lift_tracks(
        prior,
        [camera],
        keypoints,
        chosen.frame_times,
        SamplerConfig(samples=samples),
        progress=_every(5, "windows lifted", say),
    )
    return ClipTiming(
        frames=tracks.num_frames,
        tracks=tracks.num_persons,
        persons=chosen.num_persons,
        person_frames=person_frames,
        detect_s=detect_s,
        lift_s=time.perf_counter() - started,
        detect_cpu_s=detect_cpu_s,
        lift_cpu_s=time.process_time() - cpu_started,
        detect_peak_rss_mb=detect_peak,
        peak_rss_mb=peak_rss_mb(),
    )


def _every(step: int, what: str, say: Callable[[str], None]) -> Callable[[int, int], None]:
    """A ``progress(done, total)`` callback saying ``done/total what`` every ``step`` and at the end."""

    def progress(done: int, total: int) -> None:
        if done % step == 0 or done == total:
            say(f"  {done}/{total} {what}")

    return progress
