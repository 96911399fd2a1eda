"""The estimated camera's horizon in the person pictures, and the words that say how that camera was found.

The horizon is where the world's horizontal plane through the camera meets the image: the vanishing line of a
level floor, ``l = K^-T R z`` (the pixel ``(x, y)`` is on it where ``l . (x, y, 1) = 0``; lens distortion left
out, the estimated camera has none). Every point at the camera's height lies on it, so it crosses a standing
person at that height: a horizon tilted against the room's verticals, or far from where the camera's height is on
the people, shows a wrong roll or pitch at a glance. It is drawn (``HORIZON_RGB``, ``HORIZON_PX`` wide) into each
person's thumbnail where it crosses it (:func:`with_horizons`, for the report and the recording alike; the picture
first stretched up or down to it where that is near, :func:`reach_horizons`), and
:func:`camera_caption` says each quantity's value, spread and source (``meta["camera"]``).
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

HORIZON_RGB = (255, 0, 255)
HORIZON_PX = 2
HORIZON_REACH = 0.5  # a person's picture is stretched by up to this share of its height to show the horizon
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


def in_thumbnail(line: np.ndarray, box: tuple[float, float, float, float], shape: tuple[int, ...]) -> np.ndarray:
    """``line`` (3,) in image pixels as a line (3,) in the pixels of the thumbnail of ``shape`` (H, W, ...) that
    :func:`platypose.exporters.person_pictures.crop` cut from ``box`` (its rows and columns spread evenly over the
    box's)."""
    x1, y1, x2, y2 = (int(round(v)) for v in box)
    rows, cols = max(y2 - y1, 1), max(x2 - x1, 1)
    scale_y = (rows - 1) / max(shape[0] - 1, 1)
    scale_x = (cols - 1) / max(shape[1] - 1, 1)
    to_image = np.array([[scale_x, 0.0, x1], [0.0, scale_y, y1], [0.0, 0.0, 1.0]])
    mapped = to_image.T @ np.asarray(line, np.float64)
    return mapped / max(float(np.hypot(mapped[0], mapped[1])), 1e-12)


def draw_horizon(picture: np.ndarray, line: np.ndarray) -> np.ndarray:
    """A copy of ``picture`` (H, W, 3) uint8 with ``line`` (3,) (its pixels) drawn where it crosses it."""
    import cv2

    drawn = np.ascontiguousarray(picture).copy()
    ends = clip_line(line, picture.shape[1] - 1, picture.shape[0] - 1)
    if ends is not None:
        (xa, ya), (xb, yb) = np.round(ends).astype(int)
        cv2.line(drawn, (int(xa), int(ya)), (int(xb), int(yb)), HORIZON_RGB, HORIZON_PX, cv2.LINE_8)
    return drawn


def horizon_place(line: np.ndarray, shape: tuple[int, ...]) -> str | None:
    """Where ``line`` (3,) (a thumbnail's pixels) is against a picture of ``shape`` (H, W, ...): None where it
    crosses it, else "above", "below" or "beside" it."""
    height, width = shape[0] - 1, shape[1] - 1
    if clip_line(line, width, height) is not None:
        return None
    a, b, c = line
    if abs(b) < 1e-12:
        return "beside"
    return "above" if -(a * width / 2 + c) / b < 0 else "below"


def reach_horizon(line: np.ndarray, box: tuple[float, float, float, float], size: tuple[int, int]) -> tuple:
    """``box`` (x1, y1, x2, y2) px of an image of ``size`` (height, width) stretched up or down so that ``line``
    (3,) crosses it from side to side, where that takes at most ``HORIZON_REACH`` of its height more and stays in
    the image; as it is otherwise."""
    x1, y1, x2, y2 = box
    a, b, c = line
    if abs(b) < 1e-12:
        return box
    ends = [-(a * x + c) / b for x in (x1, x2)]
    low, high = min(ends) - HORIZON_PX, max(ends) + HORIZON_PX
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
        box = reach_horizon(horizon_line(camera.K, camera.R), good.box, tuple(camera.size))
        stretched[p] = replace(good, box=tuple(float(v) for v in box))
    return stretched


def with_horizons(result, frames: dict, pictures: dict[int, np.ndarray]) -> dict[int, np.ndarray]:
    """The thumbnails ``pictures`` (per person index) with their camera's horizon drawn, where the lift estimated
    its camera (``meta["camera"]``); as they are otherwise (a calibration's world need not be level)."""
    if not (result.meta or {}).get("camera"):
        return pictures
    drawn = {}
    for p, picture in pictures.items():
        camera = result.cameras[frames[p].camera]
        drawn[p] = draw_horizon(picture, in_thumbnail(horizon_line(camera.K, camera.R), frames[p].box, picture.shape))
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
    height = (meta.get("floor") or {}).get("camera_height_m")
    if height is not None:
        lines.append(f"height {height:.2f} m ({record['height_m']['source']})")
    return lines
