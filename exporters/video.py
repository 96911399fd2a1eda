"""Video helpers for the rerun export (PyAV): codec probe, H.264 re-encode, JPEG frames."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import av
import cv2
import numpy as np

from platypose.lifting.errors import InputError

# Codecs rerun's viewers decode from an MP4 asset everywhere; others are re-encoded to H.264.
PLAYABLE_CODECS = frozenset({"h264", "av1"})
PLAYABLE_CONTAINERS = frozenset({"mov,mp4,m4a,3gp,3g2,mj2"})


def _open(path: Path) -> av.container.InputContainer:
    """Open a video for reading; InputError naming the file if it cannot be read."""
    try:
        container = av.open(str(path))
    except (OSError, av.FFmpegError) as err:
        raise InputError(f"{path}: cannot read video ({err})") from None
    if not container.streams.video:
        container.close()
        raise InputError(f"{path}: has no video stream")
    return container


def needs_reencode(path: Path) -> bool:
    """True when ``path`` is not an MP4 with a codec rerun plays (H.264 or AV1)."""
    with _open(path) as container:
        codec = container.streams.video[0].codec_context.name
        return codec not in PLAYABLE_CODECS or container.format.name not in PLAYABLE_CONTAINERS


def reencode_h264(src: Path, dst: Path, crf: int = 23) -> None:
    """Re-encode the first video stream of ``src`` to H.264 MP4 at ``dst``, keeping frame timestamps.

    Odd widths or heights lose their last column or row (H.264 4:2:0 needs even sizes), so pixel
    coordinates are unchanged.
    """
    with _open(src) as inp, av.open(str(dst), "w", format="mp4") as out:
        stream_in = inp.streams.video[0]
        stream_in.thread_type = "AUTO"
        width, height = stream_in.width - stream_in.width % 2, stream_in.height - stream_in.height % 2
        stream_out = out.add_stream("libx264", rate=stream_in.average_rate or 30)
        stream_out.width, stream_out.height, stream_out.pix_fmt = width, height, "yuv420p"
        stream_out.time_base = stream_in.time_base
        stream_out.options = {"preset": "ultrafast", "crf": str(crf)}
        try:
            for frame in inp.decode(stream_in):
                if (frame.width, frame.height) != (width, height):
                    cropped = av.VideoFrame.from_ndarray(frame.to_ndarray(format="rgb24")[:height, :width], "rgb24")
                    cropped.pts, cropped.time_base = frame.pts, frame.time_base
                    frame = cropped
                out.mux(stream_out.encode(frame.reformat(format="yuv420p")))
            out.mux(stream_out.encode())
        except av.FFmpegError as err:
            raise InputError(f"{src}: cannot re-encode video ({err})") from None


def jpeg_frames(path: Path, batch: int = 64, quality: int = 85) -> Iterator[tuple[np.ndarray, list[bytes]]]:
    """Batches of (frame times (B,) seconds, JPEG bytes per frame) decoded from ``path``."""
    with _open(path) as container:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        times: list[float] = []
        blobs: list[bytes] = []
        try:
            for frame in container.decode(stream):
                ok, data = cv2.imencode(".jpg", frame.to_ndarray(format="bgr24"), [cv2.IMWRITE_JPEG_QUALITY, quality])
                if not ok:
                    raise InputError(f"{path}: cannot encode frame {len(times)} as JPEG")
                times.append(float(frame.time))
                blobs.append(data.tobytes())
                if len(blobs) == batch:
                    yield np.array(times), blobs
                    times, blobs = [], []
        except av.FFmpegError as err:
            raise InputError(f"{path}: cannot decode video ({err})") from None
        if blobs:
            yield np.array(times), blobs
