"""Video for the rerun export: codec probe, H.264 re-encode, JPEG frames; decoding by ``platypose.media``.

Frames are upright (display rotation applied) with each frame's own time, as the keypoints were
detected on, so images and keypoints line up in the viewer.
"""

from __future__ import annotations

import threading
from collections.abc import Iterator
from fractions import Fraction
from pathlib import Path

import av
import cv2
import numpy as np

from platypose.lifting.camera import SIZE_TOLERANCE
from platypose.lifting.errors import InputError
from platypose.media import converted, iter_timed_frames, open_video, video_info

# Codecs rerun's viewers decode from an MP4 asset everywhere; others are re-encoded to H.264.
PLAYABLE_CODECS = frozenset({"h264", "av1"})
PLAYABLE_CONTAINERS = frozenset({"mov,mp4,m4a,3gp,3g2,mj2"})
TIME_BASE = Fraction(1, 90000)  # output timestamps, fine enough for any frame rate


def check_video_size(path: Path, camera_name: str, camera_size: tuple[int, int]) -> None:
    """InputError unless the video ``path`` (upright) has the image size ``camera_size`` (height, width) of the
    result's camera ``camera_name``, within ``SIZE_TOLERANCE`` as the lift takes it: a resized copy would show the
    keypoints and thumbnails in the wrong place."""
    height, width = video_info(path).image_size
    if max(abs(a - b) / b for a, b in zip((height, width), camera_size)) > SIZE_TOLERANCE:
        raise InputError(
            f"{path}: the video is {width}x{height} pixels but camera {camera_name} of the result saw "
            f"{camera_size[1]}x{camera_size[0]}: not the video it was lifted from (a resized copy?)"
        )


def needs_reencode(path: Path) -> bool:
    """True when ``path`` is not an upright MP4 with a codec rerun plays (H.264 or AV1)."""
    with open_video(path) as container:
        codec = container.streams.video[0].codec_context.name
        playable = codec in PLAYABLE_CODECS and container.format.name in PLAYABLE_CONTAINERS
    return not playable or video_info(path).rotation != 0


def reencode_h264(src: Path, dst: Path, crf: int = 23, stop: threading.Event | None = None) -> bool:
    """Re-encode ``src`` upright to H.264 MP4 at ``dst``, keeping each frame's time; False (``dst`` incomplete, for
    the caller to discard) when ``stop`` was set before the last frame, True when done.

    Odd widths or heights lose their last column or row (H.264 4:2:0 needs even sizes), so pixel
    coordinates are unchanged.
    """
    info = video_info(src)
    height, width = (s - s % 2 for s in info.image_size)
    with av.open(str(dst), "w", format="mp4") as out:
        stream = out.add_stream("libx264", rate=Fraction(info.fps).limit_denominator(100000))
        stream.width, stream.height, stream.pix_fmt = width, height, "yuv420p"
        stream.time_base = TIME_BASE
        stream.options = {"preset": "ultrafast", "crf": str(crf)}
        try:
            for _, time, image in iter_timed_frames(src, fmt="rgb24"):
                if stop is not None and stop.is_set():
                    return False
                frame = av.VideoFrame.from_ndarray(np.ascontiguousarray(image[:height, :width]), "rgb24")
                frame.pts, frame.time_base = int(round(time / TIME_BASE)), TIME_BASE
                out.mux(stream.encode(converted(frame, "yuv420p")))
            out.mux(stream.encode())
        except av.FFmpegError as err:
            raise InputError(f"{src}: cannot re-encode video ({getattr(err, 'strerror', None) or err})") from None
    return True


def jpeg_frames(path: Path, batch: int = 64, quality: int = 85) -> Iterator[tuple[np.ndarray, list[bytes]]]:
    """Batches of (frame times (B,) seconds, JPEG bytes per frame) of the upright frames of ``path``."""
    times: list[float] = []
    blobs: list[bytes] = []
    for _, time, image in iter_timed_frames(path):
        ok, data = cv2.imencode(".jpg", image, [cv2.IMWRITE_JPEG_QUALITY, quality])
        if not ok:
            raise InputError(f"{path}: cannot encode frame {len(times)} as JPEG")
        times.append(time)
        blobs.append(data.tobytes())
        if len(blobs) == batch:
            yield np.array(times), blobs
            times, blobs = [], []
    if blobs:
        yield np.array(times), blobs
