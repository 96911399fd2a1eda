"""Guess what a calibration file leaves unsaid (length unit, up axis) from where its cameras are.

Both guesses rest on how capture rigs are built: cameras stand between a few decimetres and some
tens of metres apart, and are mounted roughly upright (the image's up is near the world's up).
Each guess returns a sentence for ``meta["assumptions"]`` so the user sees what was decided.
:func:`camera_doubts` says what a camera states that no real one has (a field of view wider than a fisheye's
usable part) and :func:`check_image_side` refuses images too small to show a person's joints.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from platypose.lifting.camera import Camera
from platypose.lifting.errors import InputError

MAX_RIG_SPREAD_M = 50.0  # a larger median spacing in file units means the file is not in metres
MAX_UP_ANGLE_DEG = 35.0  # the mean image-up must lie this close to one world axis to be taken as up
AXIS_NAMES = ("x", "y", "z")
MAX_FIELD_OF_VIEW_DEG = 150.0  # horizontal; a pinhole model wider than this is a wrong focal length
MIN_IMAGE_SIDE = 32  # pixels: fewer cannot show 17 joints of a person apart


def camera_doubts(camera: Camera) -> list[str]:
    """Warnings about ``camera``: a focal length that makes its horizontal field of view wider than
    ``MAX_FIELD_OF_VIEW_DEG`` (a focal length in another unit, or of another image size)."""
    fov = float(np.degrees(2 * np.arctan2(camera.width / 2, camera.K[0, 0])))
    if fov <= MAX_FIELD_OF_VIEW_DEG:
        return []
    return [
        f"camera {camera.name}: focal length {camera.K[0, 0]:g} px on a {camera.width} px wide image is a "
        f"{fov:.0f} degree field of view, wider than any lens the pinhole model fits: check the calibration's "
        "focal length (pixels, of this image size)"
    ]


def check_image_side(image_size: tuple[int, int], source: str) -> None:
    """InputError when an image (height, width) is under ``MIN_IMAGE_SIDE`` pixels on a side."""
    height, width = image_size
    if min(height, width) < MIN_IMAGE_SIDE:
        raise InputError(
            f"{source}: the image is {width}x{height} pixels; a person's joints need at least {MIN_IMAGE_SIDE} "
            "pixels a side (wrong --image-size?)"
        )


def camera_spread(cameras: Sequence[Camera]) -> float | None:
    """Median distance between camera centres in file units, or None with fewer than two distinct centres."""
    centres = np.stack([c.center for c in cameras])
    if len(centres) < 2:
        return None
    # row by row: memory stays linear in the number of cameras (the pairs are counted by check_cameras' bound)
    gaps = np.concatenate([np.linalg.norm(centres[i + 1 :] - centres[i], axis=-1) for i in range(len(centres) - 1)])
    return float(np.median(gaps)) if gaps.max() > 0 else None


def detect_units(cameras: Sequence[Camera]) -> tuple[str, str | None]:
    """``"mm"`` when the cameras are implausibly far apart in metres (median spacing over 50), else ``"m"``.

    Returns the unit and, when millimetres were chosen, the sentence saying why.
    """
    spread = camera_spread(cameras)
    if spread is None or spread <= MAX_RIG_SPREAD_M:
        return "m", None
    return "mm", (
        f"units not stated: millimetres detected (cameras a median {spread:.0f} units apart, "
        f"{spread / 1000:.2f} m in mm); pass --units to override"
    )


def detect_up(cameras: Sequence[Camera]) -> tuple[str, str | None]:
    """The signed world axis nearest the cameras' mean image-up direction, and a sentence when it is not +z.

    Falls back to ``"z"`` when the mean direction is more than 35 degrees from every axis.
    """
    ups = np.stack([-c.R[1] for c in cameras])  # image y points down: the camera's up is -y
    mean = ups.sum(axis=0)
    norm = float(np.linalg.norm(mean))
    if norm < 1e-9:
        return "z", None
    mean /= norm
    axis = int(np.argmax(np.abs(mean)))
    angle = float(np.degrees(np.arccos(np.clip(abs(mean[axis]), -1.0, 1.0))))
    name = ("-" if mean[axis] < 0 else "") + AXIS_NAMES[axis]
    if angle > MAX_UP_ANGLE_DEG or name == "z":
        return "z", None
    return name, (
        f"world up not stated: {name} detected from the cameras' image-up directions "
        f"(mean {angle:.0f} degrees from {name}); pass --world-up to override"
    )
