"""What we assume when a file says nothing: a level camera at the origin, and a field-of-view prior.

Field-of-view prior: the focal length in pixels equals the image diagonal, i.e. a
diagonal field of view of 2*atan(1/2) = 53.1 degrees (about a 43 mm lens on full
frame). CLIFF (Li et al., ECCV 2022) showed this estimate works well on
in-the-wild video; it sits between a phone's main camera in video mode (60-75
degrees diagonal) and typical lab cameras (30-50 degrees), so neither kind is far off.
"""

from __future__ import annotations

import math

import numpy as np

from platypose.lifting.calibration.model import Calibration, new_meta
from platypose.lifting.camera import Camera

DIAGONAL_FOV_DEG = math.degrees(2.0 * math.atan(0.5))

# World axes seen from a level camera at the origin looking along world +Y:
# x_cam = +X (right), y_cam = -Z (image down = world down), z_cam = +Y (forward).
LEVEL_R = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])

NO_EXTRINSICS_NOTE = "no extrinsics: camera at the world origin, level, looking along +y, world up = -y of the camera"


def fov_prior_intrinsics(height: int, width: int) -> np.ndarray:
    """Camera matrix (3, 3) with focal = image diagonal (53.1 degree diagonal FOV) and the centre at the image middle."""
    f = math.hypot(width, height) / (2.0 * math.tan(math.radians(DIAGONAL_FOV_DEG) / 2.0))
    return np.array([[f, 0.0, width / 2.0], [0.0, f, height / 2.0], [0.0, 0.0, 1.0]])


def fov_prior_note(height: int, width: int) -> str:
    """The metadata sentence recording the FOV prior for an image of this size."""
    return f"no intrinsics: focal {math.hypot(width, height):.1f} px from a {DIAGONAL_FOV_DEG:.1f} degree diagonal FOV prior, {width}x{height}"


def default_camera(name: str, height: int, width: int) -> Camera:
    """A level camera at the origin with the FOV-prior intrinsics, for a video with no calibration at all."""
    return Camera(name=name, size=(height, width), K=fov_prior_intrinsics(height, width), R=LEVEL_R)


def default_calibration(name: str, height: int, width: int, source: str) -> Calibration:
    """A one-camera calibration made only from the video size, with both assumptions stated in ``meta``."""
    meta = new_meta("default", source, "z", "m")
    meta["assumptions"] = [fov_prior_note(height, width), NO_EXTRINSICS_NOTE]
    return Calibration(cameras=(default_camera(name, height, width),), meta=meta)


def complete_camera(
    name: str,
    size: tuple[int, int],
    K: np.ndarray | None,
    dist: np.ndarray | None,
    R: np.ndarray | None,
    t: np.ndarray | None,
) -> tuple[Camera, list[str]]:
    """A camera with missing intrinsics (K None) or extrinsics (R or t None) filled by the defaults, plus notes."""
    notes = []
    if K is None:
        K = fov_prior_intrinsics(*size)
        notes.append(f"camera {name}: {fov_prior_note(*size)}")
    if R is None or t is None:
        R, t = LEVEL_R, np.zeros(3)
        notes.append(f"camera {name}: {NO_EXTRINSICS_NOTE}")
    return Camera(name=name, size=size, K=K, dist=np.zeros(5) if dist is None else dist, R=R, t=t), notes


SIZE_FROM_CENTRE_NOTE = "image size not stated: assumed twice the principal point"


def size_from_principal_point(K: np.ndarray) -> tuple[int, int]:
    """(height, width) assumed when a file gives intrinsics but no image size: twice the principal point."""
    return int(round(2 * K[1, 2])), int(round(2 * K[0, 2]))
