"""A range of a video's frames without decoding the frames before it: the stamps of every frame (read from the
packets, once, by whoever plans the ranges), then for each range a seek to the key frame before its first frame and
decoding from there. Frame ``i`` is the video's i-th frame in presentation order, as :func:`platypose.media.iter_frames`
counts them."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import av
import numpy as np

from platypose.lifting.errors import InputError
from platypose.media import iter_frames, open_video, upright


def iter_frame_range(
    path: str | Path, start: int, stamp: int | None, count: int | None, stride: int = 1
) -> Iterator[tuple[int, np.ndarray]]:
    """Yield ``(frame index, upright BGR image)`` for the every-``stride``-th frames (by index) among ``count``
    frames (None: to the end) from frame ``start``, whose stamp is ``stamp`` (:func:`platypose.media.frame_stamps`).
    Without a stamp, or where decoding after the seek does not find it, the frames are decoded from the video's start."""
    if start == 0 or stamp is None:
        yield from _from_start(path, start, count, stride)
        return
    with open_video(path) as container:
        stream = container.streams.video[0]
        stream.thread_type = "AUTO"
        container.seek(int(stamp), stream=stream, backward=True, any_frame=False)
        index = None
        try:
            for frame in container.decode(stream):
                if frame.pts is None:
                    break
                if index is None:
                    if frame.pts > stamp:  # the seek landed past the first frame: not trusted
                        break
                    if frame.pts < stamp:
                        continue
                    index = start
                if count is not None and index >= start + count:
                    return
                if index % stride == 0:
                    yield index, upright(frame)
                index += 1
        except av.FFmpegError as err:
            raise InputError(f"{path}: cannot decode video after frame {start} ({err})") from None
    if index is None:
        yield from _from_start(path, start, count, stride)


def _from_start(path: str | Path, start: int, count: int | None, stride: int) -> Iterator[tuple[int, np.ndarray]]:
    """:func:`iter_frame_range` by decoding every frame from the video's first."""
    for index, image in iter_frames(path, stride=stride):
        if count is not None and index >= start + count:
            return
        if index >= start:
            yield index, image
