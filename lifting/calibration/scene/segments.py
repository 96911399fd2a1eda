"""Line segments of a grey frame (OpenCV's line segment detector), less those on the frame's black border or on
people.

OpenCV's ``createLineSegmentDetector`` (LSD, von Gioi et al. 2012) has moved between OpenCV's main and contrib
packages before; where it is missing, :func:`line_detector` returns None and callers say "no line detector".
A segment is a row ``(x1, y1, x2, y2)`` in pixels.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np

BLACK_LEVEL = 12  # a border row or column is darker than this everywhere (letterboxing, a lens's black corners)
BORDER_MARGIN_PX = 4  # segments this near a black border are the border's edge, not the scene's
PERSON_PRESENCE = 0.3  # a pixel is masked where people's boxes cover it in this share of the frames or more

Detector = Callable[[np.ndarray], np.ndarray]


def line_detector() -> Detector | None:
    """A function from a grey image (H, W) uint8 to its segments (N, 4), or None where this OpenCV has no LSD."""
    create = getattr(cv2, "createLineSegmentDetector", None)
    if create is None:
        return None
    try:
        lsd = create()
    except cv2.error:  # builds without the (once patented) implementation raise here
        return None

    def detect(grey: np.ndarray) -> np.ndarray:
        found = lsd.detect(grey)[0]
        return np.zeros((0, 4)) if found is None else found.reshape(-1, 4).astype(np.float64)

    return detect


def content_mask(grey: np.ndarray) -> np.ndarray:
    """True (H, W) inside the frame's picture: black border rows and columns, and ``BORDER_MARGIN_PX`` next to
    them, are False (their edge is a straight line of the frame, not of the scene)."""
    rows = np.nonzero(grey.max(axis=1) > BLACK_LEVEL)[0]
    cols = np.nonzero(grey.max(axis=0) > BLACK_LEVEL)[0]
    mask = np.zeros(grey.shape, bool)
    if len(rows) == 0 or len(cols) == 0:
        return mask
    top, bottom = rows[0], rows[-1]
    left, right = cols[0], cols[-1]
    m = BORDER_MARGIN_PX
    height, width = grey.shape
    top = top + m if top > 0 else 0
    left = left + m if left > 0 else 0
    bottom = bottom - m if bottom < height - 1 else height - 1
    right = right - m if right < width - 1 else width - 1
    mask[top : bottom + 1, left : right + 1] = True
    return mask


def people_mask(shape: tuple[int, int], boxes: list[np.ndarray]) -> np.ndarray:
    """True (H, W) where people stand in ``PERSON_PRESENCE`` of the frames or more: ``boxes`` holds each frame's
    person boxes (K, 4) ``(x0, y0, x1, y1)`` px. A person who walks through is gone from the frames' median and
    is not masked; one who stays is."""
    cover = np.zeros(shape, np.float64)
    for frame_boxes in boxes:
        seen = np.zeros(shape, bool)
        for x0, y0, x1, y1 in np.asarray(frame_boxes, np.float64).reshape(-1, 4):
            if not np.all(np.isfinite([x0, y0, x1, y1])):
                continue
            seen[max(int(y0), 0) : max(int(np.ceil(y1)), 0), max(int(x0), 0) : max(int(np.ceil(x1)), 0)] = True
        cover += seen
    return cover >= PERSON_PRESENCE * max(len(boxes), 1)


def unmasked_pieces(segments: np.ndarray, allowed: np.ndarray, step_px: float = 4.0) -> np.ndarray:
    """The parts (M, 4) of the segments (N, 4) that lie where ``allowed`` (H, W) is True, tested every ``step_px``
    along them: a floor edge passing behind a person keeps its two ends (pieces shorter than two steps are
    left out)."""
    segments = np.asarray(segments, np.float64).reshape(-1, 4)
    if len(segments) == 0:
        return segments
    height, width = allowed.shape
    counts = np.maximum((lengths(segments) / step_px).astype(int), 1) + 1  # samples along each
    longest = int(counts.max())
    s = np.arange(longest)[None] / np.maximum(counts - 1, 1)[:, None]  # (N, S), past 1 beyond each's end
    x = segments[:, :1] + s * (segments[:, 2:3] - segments[:, :1])
    y = segments[:, 1:2] + s * (segments[:, 3:4] - segments[:, 1:2])
    xi, yi = np.rint(x).astype(int), np.rint(y).astype(int)
    ok = (np.arange(longest)[None] < counts[:, None]) & (xi >= 0) & (xi < width) & (yi >= 0) & (yi < height)
    ok[ok] = allowed[yi[ok], xi[ok]]
    edges = np.diff(np.pad(ok.astype(np.int8), ((0, 0), (1, 1))), axis=1)
    rows, first = np.nonzero(edges == 1)  # row-major: each row's runs in order, starts and ends alike
    last = np.nonzero(edges == -1)[1] - 1
    keep = last - first >= 2
    rows, first, last = rows[keep], first[keep], last[keep]
    return np.column_stack([x[rows, first], y[rows, first], x[rows, last], y[rows, last]])


def lengths(segments: np.ndarray) -> np.ndarray:
    """Each segment's length in pixels (N,)."""
    return np.hypot(segments[:, 2] - segments[:, 0], segments[:, 3] - segments[:, 1])


def person_boxes(keypoints: np.ndarray, min_confidence: float = 0.3, padding: float = 0.15) -> np.ndarray:
    """Boxes (P', 4) ``(x0, y0, x1, y1)`` around each person's confident keypoints (P, J, 3) in one frame, widened
    by ``padding`` of their size on every side (limbs' edges and clothes reach past the joints)."""
    boxes = []
    for person in np.asarray(keypoints, np.float64):
        seen = person[np.nan_to_num(person[:, 2]) >= min_confidence, :2]
        seen = seen[np.isfinite(seen).all(axis=1)]
        if len(seen) < 2:
            continue
        low, high = seen.min(axis=0), seen.max(axis=0)
        pad = padding * (high - low).max()
        boxes.append([*(low - pad), *(high + pad)])
    return np.array(boxes, np.float64).reshape(-1, 4)
