"""One view to 2D tracks, the one reader of ``platypose lift``, ``platypose detect``, ``platypose.lift`` and
``platypose bench``: precomputed keypoints are read, a video is detected (the model loaded once, when first needed).

The command's extras are hooks: where a view's detections are cached (``cache_dir``) and how the frames
detected are shown (``progress``); without them nothing is cached or shown.
"""

from __future__ import annotations

import time
from collections.abc import Callable
from contextlib import AbstractContextManager, nullcontext
from dataclasses import dataclass
from pathlib import Path

from platypose.detectors.models.detector import Detector
from platypose.detectors.types import PoseTrack2D
from platypose.lifting.settings import DetectOptions

Progress = Callable[[int, int], None]  # (frames done, frames in all)
ProgressHook = Callable[[Path, int], AbstractContextManager[Progress]]  # (video, frames to detect) -> its counter
Loader = Callable[[DetectOptions], Detector]


@dataclass(frozen=True)
class ViewRead:
    """A view's ``tracks``, the ``seconds`` they took, and the ``frames`` detected (None: keypoints read; 0: the
    detections came from the cache)."""

    tracks: PoseTrack2D
    seconds: float
    frames: int | None

    @property
    def how(self) -> str:
        """How the tracks were obtained, in words."""
        if self.frames is None:
            return "read"
        return "from the cache" if self.frames == 0 else f"detected in {self.frames} frames"


def load_model(options: DetectOptions) -> Detector:
    """The pose model ``options`` name (:func:`platypose.detectors.models.contracts.load_detector`)."""
    from platypose.detectors.models.contracts import load_detector

    o = options
    return load_detector(o.detector, o.detector_format, o.person_detector, o.threads, o.provider, o.movenet_size)


class ViewReader:
    """Reads or detects views as ``options`` say; ``load`` gives the model (once per reader), ``cache_dir`` a view's
    cache folder (None: no cache), ``progress`` the counter of a video's frames while they are detected."""

    def __init__(
        self,
        options: DetectOptions,
        load: Loader = load_model,
        cache_dir: Callable[[Path], Path | None] | None = None,
        progress: ProgressHook | None = None,
    ) -> None:
        self.options, self.load, self.cache_dir, self.progress = options, load, cache_dir, progress
        self.model: Detector | None = None

    def __call__(self, source: Path) -> ViewRead:
        """The tracks of the view at ``source``; InputError for a source that is neither keypoints nor a video."""
        from platypose.detectors.sources.keypoint_source import is_keypoint_source, read_keypoints

        o, started = self.options, time.perf_counter()
        if is_keypoint_source(source):
            tracks = read_keypoints(source, fps=o.fps, image_size=o.image_size)
            return ViewRead(tracks, time.perf_counter() - started, None)
        from platypose.detectors.sources.video import video_info
        from platypose.detectors.video_detection import detect_video

        info = video_info(source)
        if self.model is None:
            self.model = self.load(o)
        total = -(-info.frame_count // o.stride)
        total = min(total, o.max_frames) if o.max_frames else total
        started, done = time.perf_counter(), [0]
        with self.progress(source, total) if self.progress is not None else nullcontext(None) as shown:

            def counted(count: int, of: int) -> None:
                done[0] = count
                if shown is not None:
                    shown(count, of)

            tracks = detect_video(
                source,
                self.model,
                stride=o.stride,
                max_frames=o.max_frames,
                progress=counted,
                cache_dir=self.cache_dir(source) if self.cache_dir is not None else None,
            )
        return ViewRead(tracks, time.perf_counter() - started, done[0])
