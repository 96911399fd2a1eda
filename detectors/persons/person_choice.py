"""The ``--persons`` choice: which tracks of a take are lifted.

- ``all``: every track;
- ``largest`` or ``largest:N``: the largest one or the N largest, by size summed over frames and views;
- ids ``id:0,2`` (also ``0,2``, and one id as ``id:2`` or ``2,``): the tracks with those ids, as the outputs name
  them (``p0``, ``p2``: the CSV's ``person`` column, the BVH file names, the report's rows, the recording's labels);
- a point ``@X,Y`` (pixels of the first view): the track nearest that point in the first frame it is seen, e.g.
  the person a user clicked on in a video player; a point outside the first view's image is refused.

A plain number (``1``) is refused: it read as "the N largest" beside ids that read as "the track with that id", and
picked another person than the one meant. The choice is read, in pure Python, by
:func:`platypose.lifting.settings.choices.parse_persons` when a ``TakeSettings`` is made; here it picks the tracks.
"""

from __future__ import annotations

import numpy as np

from platypose.lifting.errors import InputError
from platypose.lifting.settings.choices import parse_persons

MIN_JOINTS = 4  # joints seen for a track to count as seen in a frame


def describe_choice(text: str, track_ids: list[int]) -> str:
    """Which rule of the ``persons`` choice ``text`` picked the tracks ``track_ids``, in words."""
    kind, value = parse_persons(text)
    picked = ", ".join(f"p{t}" for t in track_ids) or "nobody"
    if kind == "all":
        rule = "every track"
    elif kind == "count":
        rule = "the largest track" if value == 1 else f"the {value} largest by size summed over frames and views"
    elif kind == "ids":
        rule = "the tracks with these ids"
    else:
        rule = f"the track nearest pixel {value[0]:g},{value[1]:g} of the first view where it is first seen"
    return f"persons {text}: {rule}: {picked}"


def indices_of_ids(track_ids: np.ndarray, ids: list[int]) -> np.ndarray:
    """Indices into ``track_ids`` of ``ids`` (sorted); InputError naming the ids that are not there."""
    known = [int(t) for t in track_ids]
    missing = [i for i in ids if i not in known]
    if missing:
        found = ", ".join(str(t) for t in known) or "none"
        raise InputError(f"persons: no track with id {', '.join(map(str, missing))} (ids: {found})", option="persons")
    return np.array(sorted(known.index(i) for i in ids), dtype=np.intp)


def check_point_in_image(point: tuple[float, float], image_size: tuple[int, int]) -> None:
    """InputError unless ``point`` (x, y pixels) lies in an image of ``image_size`` (height, width)."""
    height, width = image_size
    if not (0 <= point[0] <= width and 0 <= point[1] <= height):
        raise InputError(
            f"persons @{point[0]:g},{point[1]:g}: the point is outside the first view's image "
            f"({width}x{height} pixels: x from 0 to {width}, y from 0 to {height})",
            option="persons",
        )


def nearest_track(keypoints: np.ndarray, point: tuple[float, float]) -> int:
    """Index along P of the track of ``keypoints`` ``(T, P, 17, 3)`` (x, y, confidence) nearest ``point`` (pixels) in
    the first frame the track is seen (at least ``MIN_JOINTS`` joints): the distance from the point to the box of its
    seen joints (0 inside; between boxes that hold the point, the nearer box centre wins)."""
    seen = np.nan_to_num(keypoints[..., 2]) > 0  # (T, P, 17)
    best, best_index = None, -1
    for p in range(keypoints.shape[1]):
        frames = np.flatnonzero(seen[:, p].sum(axis=-1) >= MIN_JOINTS)
        if not len(frames):
            continue
        joints = keypoints[frames[0], p, seen[frames[0], p], :2]
        low, high = joints.min(axis=0), joints.max(axis=0)
        outside = np.linalg.norm(np.maximum(0.0, np.maximum(low - point, np.asarray(point) - high)))
        key = (outside, np.linalg.norm((low + high) / 2 - point))
        if best is None or key < best:
            best, best_index = key, p
    if best is None:
        raise InputError(f"persons @{point[0]:g},{point[1]:g}: no track is seen", option="persons")
    return best_index
