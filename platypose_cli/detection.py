"""Turning one view (video or precomputed keypoints) into 2D tracks; shared by ``detect`` and ``lift``."""

from __future__ import annotations

import functools
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import typer


def image_size_option(value: str | None) -> tuple[int, int] | None:
    """``HEIGHTxWIDTH`` -> (height, width)."""
    from platypose.lifting.errors import InputError

    if value is None:
        return None
    height, sep, width = value.lower().partition("x")
    if not sep or not (height + width).isascii() or not height.isdigit() or not width.isdigit():
        raise InputError(f"--image-size {value}: give HEIGHTxWIDTH in pixels, e.g. 1080x1920")
    return int(height), int(width)


@dataclass(frozen=True)
class DetectOptions:
    """Settings for reading or detecting one source."""

    detector: Path | None = None
    detector_format: str | None = None
    person_detector: Path | None = None
    movenet_size: int = 384
    threads: int | None = None
    provider: str = "CPUExecutionProvider"
    stride: int = 1
    max_frames: int | None = None
    fps: float | None = None
    image_size: str | None = None
    cache: bool = True


@functools.lru_cache(maxsize=4)
def cached_detector(
    detector: Path | None,
    detector_format: str | None,
    person_detector: Path | None,
    threads: int | None,
    provider: str,
    movenet_size: int,
):
    """The detector for these options, loaded once per process (a batch worker keeps it for its next inputs)."""
    from platypose.detectors.contracts import load_detector

    return load_detector(detector, detector_format, person_detector, threads, provider, movenet_size)


class Detection:
    """Turns one source into tracks: reads precomputed keypoints or runs the (lazily loaded) model on a video."""

    def __init__(self, options: DetectOptions) -> None:
        self.options = options
        self.model = None

    def tracks(self, source: Path, folder: Path, quiet: bool):
        """(tracks, seconds, frames detected: None for precomputed keypoints, 0 when read from the cache)."""
        from platypose.detectors.sources import is_keypoint_source, read_keypoints

        o = self.options
        started = time.perf_counter()
        if is_keypoint_source(source):
            tracks = read_keypoints(source, fps=o.fps, image_size=image_size_option(o.image_size))
            return tracks, time.perf_counter() - started, None
        from platypose.detectors.pipeline import detect_video
        from platypose.detectors.video import video_info

        info = video_info(source)
        if self.model is None:
            self.model = cached_detector(
                o.detector,
                o.detector_format,
                o.person_detector,
                o.threads,
                o.provider,
                o.movenet_size,
            )
        total = -(-info.frame_count // o.stride)
        total = min(total, o.max_frames) if o.max_frames else total
        started = time.perf_counter()
        done = [0]
        with typer.progressbar(
            length=max(total, 1), label=f"detecting {source.name}", file=sys.stderr, hidden=quiet
        ) as bar:

            def progress(count: int, _total: int) -> None:
                bar.update(count - done[0])
                done[0] = count

            tracks = detect_video(
                source,
                self.model,
                stride=o.stride,
                max_frames=o.max_frames,
                progress=progress,
                cache_dir=folder if o.cache else None,
            )
        return tracks, time.perf_counter() - started, done[0]
