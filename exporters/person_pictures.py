"""Who is who: each person's image box and a thumbnail from a good frame, for the report and the recording.

A good frame of a person is one where a camera sees most of their joints inside its image (at least ``GOOD_JOINTS`` of 17, else the
most seen), where no other person covers more than ``MAX_SHARED`` of their box (when there is such a frame: two
people overlapping would otherwise get the same picture) and, among those, their box is tallest (nearest, least
hidden). The box is that of the confident joints,
widened by ``BOX_MARGIN`` of its size on every side and twice that above (a head and feet reach past their
keypoints). The thumbnail is
that box cut from the camera's video frame, scaled to ``THUMBNAIL_HEIGHT`` pixels high.
"""

from __future__ import annotations

import warnings
from collections.abc import Mapping
from dataclasses import dataclass
from pathlib import Path

import numpy as np

GOOD_JOINTS = 15
MAX_SHARED = 0.2  # share of a person's box that another person's box may cover in their good frame
BOX_MARGIN = 0.1
THUMBNAIL_HEIGHT = 160


@dataclass(frozen=True)
class GoodFrame:
    """Where a person is best seen: camera index, frame index, box (x1, y1, x2, y2) in that camera's pixels."""

    camera: int
    frame: int
    box: tuple[float, float, float, float]

    def as_dict(self, camera_name: str, time_s: float) -> dict:
        """Plain dict for meta and text: camera name, frame, time (s), box (px, rounded)."""
        return {
            "camera": camera_name,
            "frame": self.frame,
            "time_s": round(time_s, 3),
            "box_px": [round(v, 1) for v in self.box],
        }


def joint_boxes(keypoints2d: np.ndarray, seen: np.ndarray | None = None) -> tuple[np.ndarray, np.ndarray]:
    """Corners ``low``, ``high`` ``(..., 2)`` of the boxes of the seen joints of keypoints ``(..., 17, 3)`` (``seen``
    ``(..., 17)``, by default the confident ones); NaN where no joint is seen."""
    if seen is None:
        seen = np.nan_to_num(keypoints2d[..., 2]) > 0
    xy = np.where(seen[..., None], keypoints2d[..., :2], np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # all-NaN frames: no joint seen
        return np.nanmin(xy, axis=-2), np.nanmax(xy, axis=-2)


def shared(keypoints2d: np.ndarray) -> np.ndarray:
    """Per person, camera and frame ``(P, C, T)``: the largest share of the person's box that another person's box
    covers there, from keypoints ``(C, P, T, 17, 3)`` (0 where the person or everyone else is unseen)."""
    low, high = joint_boxes(np.moveaxis(np.asarray(keypoints2d), 1, 0))  # (P, C, T, 2)
    size = np.clip(high - low, 0.0, None)
    area = size[..., 0] * size[..., 1]
    most = np.zeros(area.shape)
    for q in range(len(low)):
        overlap = np.clip(np.minimum(high, high[q]) - np.maximum(low, low[q]), 0.0, None)
        share = overlap[..., 0] * overlap[..., 1] / np.where(area > 0, area, np.inf)
        share[q] = 0.0  # not with oneself
        most = np.fmax(most, np.nan_to_num(share))
    return most


def good_frame(
    keypoints2d: np.ndarray, image_sizes: list[tuple[int, int]], covered: np.ndarray | None = None
) -> GoodFrame | None:
    """The good frame of one person's keypoints ``(C, T, 17, 3)`` (x, y, confidence) seen by cameras of
    ``image_sizes`` (height, width), avoiding frames where others cover over ``MAX_SHARED`` of them (``covered``
    ``(C, T)``, :func:`shared`) when it can; None when no camera sees 4 of their joints inside its image (a joint
    outside the image, allowed in the keypoints, is not in any picture)."""
    sizes = np.asarray(image_sizes, dtype=np.float64).reshape(-1, 1, 1, 2)[..., ::-1]  # (C, 1, 1, 2) width, height
    with np.errstate(invalid="ignore"):
        inside = ((keypoints2d[..., :2] >= 0) & (keypoints2d[..., :2] <= sizes - 1)).all(axis=-1)
    seen = (np.nan_to_num(keypoints2d[..., 2]) > 0) & inside  # (C, T, 17)
    count = seen.sum(axis=-1)
    if count.max(initial=0) < 4:
        return None
    low, high = joint_boxes(keypoints2d, seen)  # (C, T, 2)
    tall = np.nan_to_num(high[..., 1] - low[..., 1])
    enough = count >= min(GOOD_JOINTS, int(count.max()))
    if covered is not None and (enough & (covered <= MAX_SHARED)).any():
        enough &= covered <= MAX_SHARED
    c, t = np.unravel_index(np.argmax(np.where(enough, tall, -1.0)), tall.shape)
    margin = BOX_MARGIN * (high[c, t] - low[c, t])
    height, width = image_sizes[c]
    x1, y1 = np.maximum(low[c, t] - margin * [1.0, 2.0], 0.0)  # twice above: the head's top is above its keypoints
    x2, y2 = np.minimum(high[c, t] + margin, [width - 1.0, height - 1.0])
    return GoodFrame(int(c), int(t), (float(x1), float(y1), float(x2), float(y2)))


def good_frames(result) -> dict[int, GoodFrame]:
    """Person index -> good frame, for every person of ``result`` (a LiftResult, keypoints2d ``(C, P, T, 17, 3)``)
    seen somewhere."""
    sizes = [tuple(c.size) for c in result.cameras]
    keypoints = np.asarray(result.keypoints2d)
    covered = shared(keypoints)
    frames = {p: good_frame(keypoints[:, p], sizes, covered[p]) for p in range(result.num_persons)}
    return {p: f for p, f in frames.items() if f is not None}


def crop(image: np.ndarray, box: tuple[float, float, float, float], height: int = THUMBNAIL_HEIGHT) -> np.ndarray:
    """``box`` cut from ``image`` ``(H, W, 3)`` and scaled (nearest pixel) to ``height`` rows."""
    x1, y1, x2, y2 = (int(round(v)) for v in box)
    part = image[y1 : max(y2, y1 + 1), x1 : max(x2, x1 + 1)]
    rows = np.linspace(0, len(part) - 1, height).round().astype(int)
    width = max(1, round(height * part.shape[1] / max(len(part), 1)))
    cols = np.linspace(0, part.shape[1] - 1, width).round().astype(int)
    return np.ascontiguousarray(part[rows][:, cols])


def thumbnails(result, video_paths: Mapping[str, Path], frames: dict[int, GoodFrame]) -> dict[int, np.ndarray]:
    """Person index -> RGB thumbnail ``(THUMBNAIL_HEIGHT, w, 3)`` uint8 of their good frame ``frames``, cut from the
    video of its camera (``video_paths`` by camera name; persons whose camera has no video get none). Each video is
    decoded once, up to the last frame needed; a video frame is matched to a result frame by time."""
    from platypose.media import iter_timed_frames

    wanted: dict[int, dict[int, list[int]]] = {}  # camera -> result frame -> persons
    for p, good in frames.items():
        if result.cameras[good.camera].name in video_paths:
            wanted.setdefault(good.camera, {}).setdefault(good.frame, []).append(p)
    half = 0.5 / result.fps
    pictures: dict[int, np.ndarray] = {}
    for c, by_frame in wanted.items():
        camera = result.cameras[c]
        times = {t: float(result.frame_times[t]) - camera.time_offset_s for t in by_frame}
        last = max(times.values())
        for _, time_s, image in iter_timed_frames(video_paths[camera.name], fmt="rgb24"):
            for t in [t for t, when in times.items() if abs(when - time_s) <= half]:
                for p in by_frame[t]:
                    pictures[p] = crop(image, frames[p].box)
                del times[t]
            if not times or time_s > last + half:
                break
    return pictures
