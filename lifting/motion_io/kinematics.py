"""Forward kinematics, axis and unit conventions shared by the skeletal motion importers."""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

# (x, y, z) Y-up -> (x, -z, y) Z-up: a proper rotation (+90 deg about x), so left stays left.
Y_UP_TO_Z_UP = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])

# Length units a mocap file may use, in metres per file unit.
LENGTH_UNITS: dict[str, float] = {"m": 1.0, "dm": 0.1, "inch": 0.0254, "cm": 0.01, "mm": 0.001}
TYPICAL_HEIGHT_M = 1.7


def y_up_to_z_up(points: np.ndarray) -> np.ndarray:
    """Rotate Y-up points ``(..., 3)`` into our Z-up world, ``(x, y, z) -> (x, -z, y)``."""
    return points @ Y_UP_TO_Z_UP.T


def detect_length_unit(height: float) -> str:
    """Unit (key of LENGTH_UNITS) that makes a skeleton of ``height`` file units closest to a standing human."""
    if not np.isfinite(height) or height <= 0:
        raise ValueError(f"skeleton height must be positive, got {height}")
    return min(LENGTH_UNITS, key=lambda u: abs(np.log(height * LENGTH_UNITS[u] / TYPICAL_HEIGHT_M)))


def rate_from_step(step: float) -> float:
    """Frames per second from a frame step in seconds, snapped to a whole rate when within 0.05% (0.033333 s -> 30)."""
    rate = 1.0 / step
    return float(round(rate)) if abs(rate - round(rate)) < 5e-4 * rate else rate


def forward_kinematics(parents: Sequence[int], offsets: np.ndarray, rotations: np.ndarray) -> np.ndarray:
    """World positions ``(T, J, 3)`` of a joint tree (parents listed before children).

    ``offsets`` ``(J, 3)`` or ``(T, J, 3)``: each joint's position in its parent's
    frame (the root's: its world position); ``rotations`` ``(T, J, 3, 3)``: each
    joint's frame relative to its parent's.
    """
    num_frames, num_joints = rotations.shape[:2]
    offsets = np.broadcast_to(offsets, (num_frames, num_joints, 3))
    world_rot = np.empty_like(rotations)
    positions = np.empty((num_frames, num_joints, 3))
    for j, p in enumerate(parents):
        if p < 0:
            world_rot[:, j] = rotations[:, j]
            positions[:, j] = offsets[:, j]
        else:
            if p >= j:
                raise ValueError(f"joint {j} listed before its parent {p}")
            world_rot[:, j] = world_rot[:, p] @ rotations[:, j]
            positions[:, j] = positions[:, p] + np.einsum("tab,tb->ta", world_rot[:, p], offsets[:, j])
    return positions
