"""The ``--persons`` choice: which tracks of a take are lifted.

- ``all``: every track;
- ``largest`` or ``N``: the largest one or the N largest, by size summed over frames and views;
- ids ``0,2`` (a single one as ``2,``): the tracks with those ids, as the outputs name them (``p0``, ``p2``: the
  CSV's ``person`` column, the BVH file names, the report's rows, the recording's labels);
- a point ``@X,Y`` (pixels of the first view): the track nearest that point in the first frame it is seen, e.g.
  the person a user clicked on in a video player.
"""

from __future__ import annotations

import numpy as np

from platypose.lifting.errors import InputError

MIN_JOINTS = 4  # joints seen for a track to count as seen in a frame
CHOICES = "'all', 'largest', a number N (the N largest), ids such as 0,2 (one id: 2,) or a pixel @X,Y"


def parse_persons(text: str) -> tuple[str, object]:
    """``("all", None)``, ``("count", N)`` (largest: 1), ``("ids", [id, ...])`` or ``("point", (x, y))``;
    InputError naming the option otherwise."""
    spec = text.strip()
    if spec == "all":
        return "all", None
    if spec == "largest":
        return "count", 1
    if spec.isdigit() and int(spec) > 0:
        return "count", int(spec)
    try:
        if spec.startswith("@"):
            x, y = (float(v) for v in spec[1:].split(","))
            if np.isfinite([x, y]).all():
                return "point", (x, y)
        elif "," in spec:
            ids = [int(v) for v in spec.split(",") if v.strip()]
            if ids and min(ids) >= 0:
                return "ids", sorted(set(ids))
    except ValueError:
        pass
    raise InputError(f"persons must be {CHOICES}, got {text!r}", option="persons")


def indices_of_ids(track_ids: np.ndarray, ids: list[int]) -> np.ndarray:
    """Indices into ``track_ids`` of ``ids`` (sorted); InputError naming the ids that are not there."""
    known = [int(t) for t in track_ids]
    missing = [i for i in ids if i not in known]
    if missing:
        found = ", ".join(str(t) for t in known) or "none"
        raise InputError(f"persons: no track with id {', '.join(map(str, missing))} (ids: {found})", option="persons")
    return np.array(sorted(known.index(i) for i in ids), dtype=np.intp)


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
