"""The estimated camera's horizon in the person pictures, and the words that say how that camera was found.

The horizon is where the world's horizontal plane through the camera meets the image: the vanishing line of a
level floor, ``l = K^-T R z`` (the pixel ``(x, y)`` of the undistorted image is on it where ``l . (x, y, 1) = 0``),
and through a lens's distortion (the scene's, for a wide lens) the curve that line bends to (:func:`horizon_curve`,
a polyline of pixels). Every point at the camera's height lies on it, so it crosses a standing person at that
height: a horizon tilted against the room's verticals, or far from where the camera's height is on the people,
shows a wrong roll or pitch at a glance. It is drawn (``HORIZON_RGB``, ``HORIZON_PX`` wide) into each person's
thumbnail where it crosses it (:func:`with_horizons`, for the report and the recording alike; the picture first
stretched up or down to it where that is near, :func:`reach_horizons`), and :func:`camera_caption` says each
quantity's value, spread and source (``meta["camera"]``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from platypose.lifting.camera import Camera, project, undistort_normalized

HORIZON_RGB = (255, 0, 255)
HORIZON_PX = 2
HORIZON_REACH = 0.5  # a person's picture is stretched by up to this share of its height to show the horizon
HORIZON_SAMPLES = 65  # points of a distorted horizon's polyline
BORDER_SAMPLES = 33  # points per side of the image whose undistorted place bounds what the lens shows
QUANTITIES = (("roll_deg", "roll", "deg", 1), ("pitch_deg", "pitch (down)", "deg", 1), ("focal_px", "focal", "px", 0))


def horizon_line(K: np.ndarray, R: np.ndarray) -> np.ndarray:
    """The horizon (3,) of a camera ``K`` (3, 3), ``R`` (3, 3) world->camera in a z-up world: the homogeneous
    image line ``a x + b y + c = 0``, scaled so ``(a, b)`` is a unit normal."""
    line = np.linalg.inv(np.asarray(K, np.float64)).T @ np.asarray(R, np.float64) @ np.array([0.0, 0.0, 1.0])
    return line / max(float(np.hypot(line[0], line[1])), 1e-12)


def clip_line(line: np.ndarray, width: float, height: float) -> np.ndarray | None:
    """The ends (2, 2) (x, y) of the part of ``line`` (3,) inside the rectangle ``[0, width] x [0, height]``, or None
    where it misses it."""
    a, b, c = line
    found = []
    for x in (0.0, width):
        if abs(b) > 1e-12:
            found.append((x, -(a * x + c) / b))
    for y in (0.0, height):
        if abs(a) > 1e-12:
            found.append((-(b * y + c) / a, y))
    inside = [p for p in found if -1e-9 <= p[0] <= width + 1e-9 and -1e-9 <= p[1] <= height + 1e-9]
    if len(inside) < 2:
        return None
    points = np.array(inside)
    along = points @ np.array([-b, a])
    ends = points[[int(np.argmin(along)), int(np.argmax(along))]]
    return None if np.allclose(ends[0], ends[1]) else ends


def horizon_curve(camera: Camera) -> np.ndarray | None:
    """The horizon of ``camera`` as its image shows it, the part inside the image: pixels (M, 2) along it (its two
    ends for a lens without distortion, ``HORIZON_SAMPLES`` points along the bent line through one with), or None
    where it misses the image."""
    line = horizon_line(camera.K, camera.R)
    if not np.any(camera.dist):
        return clip_line(line, camera.width, camera.height)
    x0, y0, x1, y1 = _undistorted_extent(camera)
    shifted = line + np.array([0.0, 0.0, line[0] * x0 + line[1] * y0])  # the line with (x0, y0) as the origin
    ends = clip_line(shifted, x1 - x0, y1 - y0)
    if ends is None:
        return None
    straight = np.linspace(ends[0], ends[1], HORIZON_SAMPLES) + np.array([x0, y0])
    rays = np.column_stack([straight, np.ones(len(straight))]) @ np.linalg.inv(camera.K).T
    bent = project(rays, replace(camera, R=np.eye(3), t=np.zeros(3)))
    inside = (bent >= -1.0).all(axis=1) & (bent[:, 0] <= camera.width + 1.0) & (bent[:, 1] <= camera.height + 1.0)
    return bent[inside] if inside.sum() >= 2 else None


def _undistorted_extent(camera: Camera) -> tuple[float, float, float, float]:
    """The box ``x0, y0, x1, y1`` (undistorted pixels) around where the image's border lies once undistorted."""
    along = np.linspace(0.0, 1.0, BORDER_SAMPLES)
    width, height = camera.width, camera.height
    border = np.concatenate(
        [
            np.column_stack([along * width, np.zeros_like(along)]),
            np.column_stack([along * width, np.full_like(along, height)]),
        ]
        + [
            np.column_stack([np.zeros_like(along), along * height]),
            np.column_stack([np.full_like(along, width), along * height]),
        ]
    )
    normalised = undistort_normalized(border, camera.K, camera.dist)
    straight = np.column_stack([normalised, np.ones(len(normalised))]) @ camera.K.T
    return (*straight[:, :2].min(axis=0), *straight[:, :2].max(axis=0))


def in_thumbnail(points: np.ndarray, box: tuple[float, float, float, float], shape: tuple[int, ...]) -> np.ndarray:
    """Image pixels ``points`` (M, 2) in the pixels of the thumbnail of ``shape`` (H, W, ...) that
    :func:`platypose.exporters.person_pictures.crop` cut from ``box`` (its rows and columns spread evenly over the
    box's)."""
    x1, y1, x2, y2 = (int(round(v)) for v in box)
    rows, cols = max(y2 - y1, 1), max(x2 - x1, 1)
    scale = np.array([(cols - 1) / max(shape[1] - 1, 1), (rows - 1) / max(shape[0] - 1, 1)])
    return (np.asarray(points, np.float64) - np.array([x1, y1])) / np.maximum(scale, 1e-12)


def draw_horizon(picture: np.ndarray, points: np.ndarray | None) -> np.ndarray:
    """A copy of ``picture`` (H, W, 3) uint8 with the horizon's ``points`` (M, 2) (its pixels; None: none) drawn
    where it crosses it."""
    import cv2

    drawn = np.ascontiguousarray(picture).copy()
    if points is not None:  # ends within the image the curve was cut to, so a few picture sizes away at most
        pixels = np.round(points).astype(np.int32)
        cv2.polylines(drawn, [pixels.reshape(-1, 1, 2)], False, HORIZON_RGB, HORIZON_PX, cv2.LINE_8)
    return drawn


def horizon_place(points: np.ndarray | None, shape: tuple[int, ...]) -> str | None:
    """Where the horizon's ``points`` (M, 2) (a thumbnail's pixels) are against a picture of ``shape`` (H, W, ...):
    None where they cross it, else "above", "below" or "beside" it."""
    height, width = shape[0] - 1, shape[1] - 1
    if points is None or len(points) < 2:
        return "beside"
    over = _heights_over(points, 0.0, width)
    if over is None:
        return "beside"
    if (over >= 0.0).any() and (over <= height).any():
        return None
    return "above" if (over < 0.0).all() else "below"


def _heights_over(points: np.ndarray, left: float, right: float) -> np.ndarray | None:
    """The curve ``points`` (M, 2)'s y at ``left``, at ``right`` and at its points between (x sorted), or None where
    it does not span that stretch."""
    order = np.argsort(points[:, 0])
    x, y = points[order, 0], points[order, 1]
    if x[0] > left + 1e-9 or x[-1] < right - 1e-9:
        return None
    between = y[(x > left) & (x < right)]
    return np.concatenate([np.interp([left, right], x, y), between])


def reach_horizon(points: np.ndarray | None, box: tuple[float, float, float, float], size: tuple[int, int]) -> tuple:
    """``box`` (x1, y1, x2, y2) px of an image of ``size`` (height, width) stretched up or down so that the horizon's
    ``points`` (M, 2) cross it from side to side, where that takes at most ``HORIZON_REACH`` of its height more and
    stays in the image; as it is otherwise."""
    x1, y1, x2, y2 = box
    over = None if points is None or len(points) < 2 else _heights_over(np.asarray(points, np.float64), x1, x2)
    if over is None:
        return box
    low, high = over.min() - HORIZON_PX, over.max() + HORIZON_PX
    reach = HORIZON_REACH * (y2 - y1)
    if low < y1 and y1 - low <= reach and low >= 0.0:
        y1 = low
    if high > y2 and high - y2 <= reach and high <= size[0] - 1.0:
        y2 = high
    return (x1, y1, x2, y2)


def reach_horizons(result, frames: dict) -> dict:
    """The good frames ``frames`` (per person index, :class:`platypose.exporters.person_pictures.GoodFrame`) with
    their boxes stretched to the horizon (:func:`reach_horizon`) where the lift estimated its camera; as they are
    otherwise."""
    if not (result.meta or {}).get("camera"):
        return frames
    stretched = {}
    for p, good in frames.items():
        camera = result.cameras[good.camera]
        box = reach_horizon(horizon_curve(camera), good.box, tuple(camera.size))
        stretched[p] = replace(good, box=tuple(float(v) for v in box))
    return stretched


def with_horizons(result, frames: dict, pictures: dict[int, np.ndarray]) -> dict[int, np.ndarray]:
    """The thumbnails ``pictures`` (per person index) with their camera's horizon drawn, where the lift estimated
    its camera (``meta["camera"]``); as they are otherwise (a calibration's world need not be level)."""
    if not (result.meta or {}).get("camera"):
        return pictures
    drawn = {}
    for p, picture in pictures.items():
        curve = horizon_curve(result.cameras[frames[p].camera])
        drawn[p] = draw_horizon(picture, None if curve is None else in_thumbnail(curve, frames[p].box, picture.shape))
    return drawn


def camera_caption(meta: dict) -> list[str]:
    """One line per quantity of the camera a lift estimated (``meta`` a LiftResult's: ``camera``, ``floor``): its
    value, standard deviation and source, each source dropped and why; empty where the lift had a calibration."""
    record = meta.get("camera") or {}
    if not record:
        return []
    if "roll_deg" not in record:
        return [f"camera: {record.get('source', 'assumed')} ({record.get('scene', '')})"]
    lines = []
    for key, name, unit, digits in QUANTITIES:
        entry = record[key]
        spread = "" if entry.get("sd") is None else f" +- {entry['sd']:.{digits}f}"
        lines.append(f"{name} {entry['value']:.{digits}f}{spread} {unit} ({entry['source']})")
        for dropped in entry.get("dropped", []):
            lines.append(
                f"  {name} from {dropped['source']} ({dropped['value']:.{digits}f} +- {dropped['sd']:.{digits}f})"
                f" dropped: {dropped['why']}"
            )
    if "focal_note" in record:
        lines.append(record["focal_note"])
    lens = record.get("distortion")
    if lens is not None:
        lines.append(f"lens distortion k {lens['value']:+.2f} ({lens['source']})" if lens["value"] else lens["source"])
    height = (meta.get("floor") or {}).get("camera_height_m")
    if height is not None:
        lines.append(f"height {height:.2f} m ({record['height_m']['source']})")
    return lines
