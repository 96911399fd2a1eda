"""A person's size across a gap: one body before and after it, or the keypoints after it disagree.

Unseen for a while, a person comes back where the images and the floor put them (:mod:`lifting.finish.steady_depth`,
:meth:`lifting.sampling.grounding.Grounding.place`). With one view, where they are and how large they are go
together: scaled about the camera, a body nearer is a body smaller. So if the body the lift has after a gap is
not the one it had before (the sum of limb and trunk lengths, ``SIZE_BONES``, median over the second seen on
either side, median over the hypotheses), the keypoints after it disagree with those before: another person took
the track over, or the floor or the depth before it is off (the Sports2D man, back on the floor after 1.5 s, was
1.4-1.6 times his size on the roof). The lift makes one body of both (:mod:`lifting.finish.rigid`), a compromise
that lifts his feet off the floor; the person is flagged once (``size after gap``), with the first such gap.
"""

from __future__ import annotations

import numpy as np

from platypose.lifting.skeleton import SIZE_BONES, bone_lengths
from platypose.lifting.tracks.roots import MIN_SEEN_JOINTS

MIN_GAP_S = 0.5  # seconds unseen: a gap whose two sides are compared
SIDE_S = 1.0  # seconds seen on either side over which the body's size is taken
SIZE_CHANGE = 0.15  # a body this much larger or smaller after a gap than before it is flagged


def body_sizes(hypotheses, p: int, chunk: int = 1024) -> np.ndarray:
    """The sum of limb and trunk lengths ``(N, T)`` of person ``p`` of ``hypotheses`` ``(P, N, T, 17, 3)`` (an array
    or anything indexed like one), ``chunk`` frames at a time; NaN where absent."""
    T = hypotheses.shape[2]
    parts = [np.asarray(hypotheses[p, :, s : s + chunk], np.float64) for s in range(0, T, chunk)]
    return np.concatenate([bone_lengths(part)[..., list(SIZE_BONES)].sum(-1) for part in parts], axis=1)


def size_after_gap(size: np.ndarray, seen: np.ndarray, fps: float) -> dict | None:
    """The first gap of a person whose body sizes are ``size`` ``(N, T)`` (:func:`body_sizes`; ``seen`` ``(T,)``
    joints seen per frame) after which their body is ``SIZE_CHANGE`` or more larger or smaller than before it:
    ``{"first_frame", "last_frame", "ratio"}`` (the gap's frames, after / before), or None."""
    unseen = np.asarray(seen) < MIN_SEEN_JOINTS
    side = max(1, round(SIDE_S * fps))
    edges = np.flatnonzero(np.diff(np.concatenate([[0], unseen.astype(np.int8), [0]])))
    for first, stop in zip(edges[::2], edges[1::2]):
        if first == 0 or stop == len(unseen) or stop - first < MIN_GAP_S * fps:
            continue
        before = _seen_median(size, unseen, slice(first - side, first))
        after = _seen_median(size, unseen, slice(stop, stop + side))
        ratios = after / before
        if not np.isfinite(ratios).any():
            continue
        ratio = float(np.nanmedian(ratios))
        if abs(np.log(ratio)) > np.log(1 + SIZE_CHANGE):
            return {"first_frame": int(first), "last_frame": int(stop - 1), "ratio": round(ratio, 2)}
    return None


def _seen_median(size: np.ndarray, unseen: np.ndarray, part: slice) -> np.ndarray:
    """Each hypothesis's median size ``(N,)`` over the seen frames of ``part`` (NaN where none)."""
    start = max(part.start, 0)
    values = np.where(unseen[start : part.stop], np.nan, size[:, start : part.stop])
    known = np.isfinite(values).any(axis=1)
    medians = np.full(len(size), np.nan)
    medians[known] = np.nanmedian(values[known], axis=1)
    return medians
