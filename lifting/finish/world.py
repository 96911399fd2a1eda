"""The estimated world: the frame a one-camera lift is written in once its floor is estimated.

Without a calibration the camera is assumed level at the origin (:mod:`lifting.calibration.defaults`), and the
floor estimated under a quick lift (:mod:`lifting.floor`) is a tilted plane somewhere below it. Outputs in that
camera-centred frame stand on nothing and lean. The estimated world moves everything rigidly so that:

- z = 0 is the estimated floor and z points up (along the floor's normal);
- the camera stands on the z axis at its estimated height above the floor, pitched as estimated;
- y is the camera's viewing direction along the floor, x = y x z (to its right).

Heights are then z, and people stand upright on z = 0. A rigid move changes no image: every camera moves with the
points (``R' = R Q^T``, ``t' = t - R' s`` for points moved ``x' = Q x + s``).
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from platypose.lifting.calibration.pose_above_floor import pitched
from platypose.lifting.camera import Camera
from platypose.lifting.floor import Floor

FLOOR = Floor((0.0, 0.0, 1.0), 0.0, "estimated")  # the estimated floor, in the estimated world


@dataclass(frozen=True)
class WorldMove:
    """The rigid move ``x' = rotation @ x + shift`` of points in metres."""

    rotation: np.ndarray  # (3, 3)
    shift: np.ndarray  # (3,)

    def points(self, points: np.ndarray) -> np.ndarray:
        """Points ``(..., 3)`` moved (NaN stays NaN), in their own dtype."""
        points = np.asarray(points)
        moved = points.astype(np.float64) @ self.rotation.T + self.shift
        return moved.astype(points.dtype, copy=False)

    def camera(self, camera: Camera) -> Camera:
        """``camera`` moved with the points: it sees every moved point where it saw the point."""
        rotation = camera.R @ self.rotation.T
        return replace(camera, R=rotation, t=camera.t - rotation @ self.shift)


def floor_world(floor: Floor, camera: Camera) -> WorldMove:
    """The move into the estimated world of ``floor`` seen by ``camera`` (see the module)."""
    up = np.asarray(floor.normal, np.float64)
    up = up / np.linalg.norm(up)
    forward = camera.R[2] - (camera.R[2] @ up) * up  # the optical axis along the floor
    if np.linalg.norm(forward) < 1e-6:  # a camera looking straight down: its image's up is forward
        forward = -camera.R[1] - (-camera.R[1] @ up) * up
    forward = forward / np.linalg.norm(forward)
    rotation = np.stack([np.cross(forward, up), forward, up])
    centre = rotation @ camera.center
    return WorldMove(rotation, np.array([-centre[0], -centre[1], floor.offset]))


def move_frames(array, move: WorldMove, chunk: int = 1024) -> None:
    """Move the points of ``array`` ``(..., T, 17, 3)`` (in memory, or a file indexed like one) in place, ``chunk``
    frames at a time along its third-last axis."""
    frames = array.shape[-3]
    for start in range(0, frames, chunk):
        block = (..., slice(start, start + chunk), slice(None), slice(None))
        array[block] = move.points(np.asarray(array[block]))


def world_note(height_m: float, pitch_deg: float) -> str:
    """The sentence that says outputs are in the estimated world (meta, log, report)."""
    return (
        f"estimated world: z = 0 is the estimated floor, z up; the camera {height_m:.2f} m above it on the z axis, "
        f"{pitched(pitch_deg)}, looking along +y"
    )


def level_on_floor(floor: Floor, camera: Camera, arrays) -> tuple[Camera, dict]:
    """Move ``arrays`` (each ``(..., T, 17, 3)``, in place) and the one ``camera`` into the world of the estimated
    ``floor``; the moved camera and the floor's ``meta`` entry there: the floor z = 0 (``FLOOR``), the camera's
    height and pitch as the estimate found them (``floor.found``), and ``frame`` (:func:`world_note`)."""
    move = floor_world(floor, camera)
    for array in arrays:
        move_frames(array, move)
    note = world_note(floor.found["camera_height_m"], floor.found["camera_pitch_deg"])
    return move.camera(camera), {**FLOOR.as_dict(), **floor.found, "frame": note}
