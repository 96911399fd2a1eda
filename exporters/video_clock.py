"""A video's frames on the output's clock: which output frame each video frame shows, and at what stamp."""

from __future__ import annotations

import numpy as np

import platypose.exporters.rerun_adapter as rra


def video_stamps(video_seconds: np.ndarray, frame_times: np.ndarray, fps: float) -> tuple[np.ndarray, np.ndarray]:
    """Clock stamps (ns) and output frame indices (-1: none) of video frames at ``video_seconds`` (V,) on the clock.

    A video frame within half an output frame of an output frame's time takes that frame's exact
    stamp and index (the nearest one only, when several video frames are that close); any other
    keeps its own time and no index.
    """
    stamps = rra.nanoseconds(video_seconds)
    frames = np.full(len(stamps), -1, dtype=np.int64)
    if len(stamps) == 0:
        return stamps, frames
    last = len(frame_times) - 1
    after = np.clip(np.searchsorted(frame_times, video_seconds), 0, last)
    before = np.clip(after - 1, 0, last)
    closer_before = np.abs(frame_times[before] - video_seconds) <= np.abs(frame_times[after] - video_seconds)
    nearest = np.where(closer_before, before, after)
    gap = np.abs(frame_times[nearest] - video_seconds)
    close = gap <= 0.5 / fps
    order = np.lexsort((gap, nearest))  # for each output frame, its closest video frame first
    first = np.ones(len(order), dtype=bool)
    first[1:] = nearest[order][1:] != nearest[order][:-1]
    keep = np.zeros(len(stamps), dtype=bool)
    keep[order[first]] = True
    keep &= close
    frames[keep] = nearest[keep]
    stamps[keep] = rra.nanoseconds(frame_times[nearest[keep]])
    return stamps, frames
