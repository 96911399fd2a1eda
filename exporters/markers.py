"""Marker trajectories for biomechanics tools: Pose2Sim marker names, OpenSim axes.

OpenSim's inverse kinematics stops on NaN, so the TRC and C3D files hold every
frame, filled by the one gap rule of :mod:`exporters.gaps`.
"""

from __future__ import annotations

import numpy as np

from platypose.exporters.frames import Lead, frame_chunks

# Pose2Sim's names of the Human3.6M joints, in our joint order.
MARKER_NAMES: tuple[str, ...] = (
    "Hip",
    "RHip",
    "RKnee",
    "RAnkle",
    "LHip",
    "LKnee",
    "LAnkle",
    "Spine",
    "Thorax",
    "Neck",
    "Head",
    "LShoulder",
    "LElbow",
    "LWrist",
    "RShoulder",
    "RElbow",
    "RWrist",
)


def to_opensim_axes(points: np.ndarray) -> np.ndarray:
    """Our Z-up points (..., 3) -> OpenSim's Y-up axes as Pose2Sim writes them: (x, y, z) -> (y, z, x)."""
    return np.asarray(points, dtype=np.float64)[..., [1, 2, 0]]


def read_frames(joints: np.ndarray | Lead) -> np.ndarray:
    """All frames of ``joints`` (T, 17, 3) as float64, read a chunk at a time."""
    return np.concatenate([np.asarray(joints[t], dtype=np.float64) for t in frame_chunks(len(joints))])
