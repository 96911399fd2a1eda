"""Radial lens distortion from the scene's lines: the distortion under which the scene's three directions explain
most of its lines (a wide lens bends straight edges; undistorted, they point at their vanishing points again).

The model is the one-parameter division model (Fitzgibbon, CVPR 2001): a distorted point ``x_d`` undistorts to
``x_d / (1 + k |x_d|^2)``, in the normalised coordinates of :mod:`platypose.lifting.calibration.scene.lines` (about
the image centre, over half its diagonal); ``k < 0`` is barrel distortion (wide lenses), ``k > 0`` pincushion. It
is closed-form both ways and one number covers the common lenses, so a search over ``k`` alone is enough
(:func:`straightest`). A lift's camera takes OpenCV's coefficients fitted to it over the image
(:func:`opencv_coefficients`), which every part of the lift already undistorts keypoints with.
"""

from __future__ import annotations

from collections.abc import Callable

import cv2
import numpy as np

from platypose.lifting.calibration.scene.lines import image_scale

STEP = 0.1  # the search's step in k (at the image's corner: 10 % of the radius)
LIMITS = (-0.6, 0.2)  # k searched: from a strong barrel (an action camera's wide view) to a strong pincushion
MIN_GAIN = 0.05  # share of the lines' length a distortion must explain beyond none to count as measured (a mild
# lens, which gains less, barely moves the roll and pitch: a drawn room under k1 = -0.05 gains 0.017)
SOURCE = "scene lines (straightest under the division model)"
NONE_SEEN = "no lens distortion seen in the scene's lines"


def undistort_pixels(points: np.ndarray, size: tuple[int, int], k: float) -> np.ndarray:
    """Pixels ``(..., 2)`` of an image ``size`` (height, width) undistorted by the division model's ``k``."""
    if k == 0.0:
        return np.asarray(points, np.float64).copy()
    centre = np.array([size[1], size[0]], np.float64) / 2.0
    scale = image_scale(size)
    normalised = (np.asarray(points, np.float64) - centre) / scale
    radius2 = (normalised**2).sum(axis=-1, keepdims=True)
    return normalised / (1.0 + k * radius2) * scale + centre


def undistort_segments(segments: np.ndarray, size: tuple[int, int], k: float) -> np.ndarray:
    """Segments ``(N, 4)`` px with both ends undistorted by the division model's ``k``: each end of a piece of a
    bent edge lies on the straight edge, so the piece's chord does too."""
    return undistort_pixels(np.asarray(segments, np.float64).reshape(-1, 2), size, k).reshape(-1, 4)


def straightest(score: Callable[[float], float]) -> tuple[float, dict[float, float]]:
    """The ``k`` within ``LIMITS`` whose ``score(k)`` (the share of the lines' length explained) is highest, and
    every score computed (``score`` is called once per ``k``, rounded to 6 decimals). Every ``STEP`` over
    ``LIMITS`` is scored (under a strong distortion the score is not monotone: the camera found jumps between
    basins, and a sharp peak stands at the true ``k``), then the vertex of the parabola through the best and its
    two neighbours is taken where it scores higher. A ``k`` that explains less than ``MIN_GAIN`` more than none is
    not measured: 0."""
    scores: dict[float, float] = {}

    def at(k: float) -> float:
        if k not in scores:
            scores[k] = score(k)
        return scores[k]

    steps = np.arange(round(LIMITS[0] / STEP), round(LIMITS[1] / STEP) + 1)
    best = max((round(float(n) * STEP, 6) for n in steps), key=at)
    low, high = round(best - STEP, 6), round(best + STEP, 6)
    if low in scores and high in scores:
        curvature = at(low) - 2 * at(best) + at(high)
        if curvature < 0:
            vertex = round(best + 0.5 * STEP * (at(low) - at(high)) / curvature, 6)
            if at(vertex) > at(best):
                best = vertex
    if at(best) < at(0.0) + MIN_GAIN:
        best = 0.0
    return best, scores


def opencv_coefficients(k: float, size: tuple[int, int], focal_px: float) -> np.ndarray:
    """OpenCV's distortion ``(k1, k2, 0, 0, k3, k4, k5, k6)`` (radii over the focal length) for the division model's
    ``k`` over the image of ``size`` (height, width) seen at ``focal_px``: zeros for ``k = 0``.

    The division model bends an undistorted radius ``r`` to ``r * 2 / (1 + sqrt(1 - 4 k r^2))`` (normalised units),
    a smooth function of ``s = r^2``. A barrel (``k < 0``) takes the rational model, a ratio of two cubics in ``s``
    (a strong barrel's edge is beyond any polynomial's reach; the denominator has no root for ``s >= 0``); a
    pincushion, whose division model ends a little past the image, the polynomial (k1 k2 k3), which has no pole
    for points projected past the image's edge. Both are fitted in linear least squares out to its corner."""
    coefficients = np.zeros(8)
    if k == 0.0:
        return coefficients
    distorted = np.linspace(0.0, 1.0, 60)  # radii out to the image's corner, normalised
    undistorted = distorted / (1.0 + k * distorted**2)
    s = (undistorted * image_scale(size) / focal_px) ** 2  # squared undistorted radius, over the focal length
    gain = distorted / np.maximum(undistorted, 1e-12)  # distorted over undistorted radius (1 at the centre)
    powers = np.column_stack([s, s**2, s**3])
    if k > 0:  # gain = 1 + k1 s + k2 s^2 + k3 s^3
        coefficients[[0, 1, 4]] = np.linalg.lstsq(powers, gain - 1.0, rcond=None)[0]
    else:  # gain (1 + k4 s + k5 s^2 + k6 s^3) = 1 + k1 s + k2 s^2 + k3 s^3, linear in the six
        design = np.hstack([powers, -gain[:, None] * powers])
        coefficients[[0, 1, 4, 5, 6, 7]] = np.linalg.lstsq(design, gain - 1.0, rcond=None)[0]
    return coefficients


def bent_image(image: np.ndarray, k: float) -> tuple[np.ndarray, float]:
    """``image`` (H, W[, 3]) as a lens of the division model's ``k`` would show its scene, and the zoom by which its
    focal length grows: the picture is enlarged just enough that every pixel of the bent image comes from inside
    the original (a barrel's corners reach past it). For checking the search on real frames of a known camera
    (``tools/scene_camera_figures.py --bend``)."""
    size = image.shape[:2]
    columns, rows = np.meshgrid(np.arange(size[1], dtype=np.float64), np.arange(size[0], dtype=np.float64))
    straight = undistort_pixels(np.stack([columns, rows], axis=-1), size, k)  # where each bent pixel looks
    centre = np.array([size[1], size[0]], np.float64) / 2.0
    half = np.array([size[1], size[0]], np.float64) / 2.0 - 0.5
    zoom = max(1.0, float((np.abs(straight - centre) / half).max()))
    source = centre + (straight - centre) / zoom
    maps = source.astype(np.float32)
    bent = cv2.remap(image, maps[..., 0], maps[..., 1], cv2.INTER_LINEAR, borderMode=cv2.BORDER_REPLICATE)
    return bent, zoom
