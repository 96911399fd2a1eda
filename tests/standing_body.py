"""A standing person on our skeleton, shared by the tests of the body checks and of steady depth."""

from __future__ import annotations

import numpy as np

from platypose.lifting.skeleton import JOINT_INDEX


def standing(frames: int = 20, knee_bend_deg: float = 10.0) -> np.ndarray:
    """A person 1.75 m tall facing +y (their right is +x), z up, knees bent forwards by ``knee_bend_deg``."""
    j = {
        "pelvis": (0.0, 0.0, 0.95),
        "right_hip": (0.1, 0.0, 0.95),
        "left_hip": (-0.1, 0.0, 0.95),
        "spine": (0.0, 0.0, 1.2),
        "thorax": (0.0, 0.0, 1.45),
        "neck": (0.0, 0.0, 1.55),
        "head": (0.0, 0.0, 1.65),
        "right_shoulder": (0.2, 0.0, 1.45),
        "left_shoulder": (-0.2, 0.0, 1.45),
        "right_elbow": (0.2, 0.0, 1.15),
        "left_elbow": (-0.2, 0.0, 1.15),
        "right_wrist": (0.2, 0.05, 0.9),
        "left_wrist": (-0.2, 0.05, 0.9),
    }
    bend = np.radians(knee_bend_deg)
    for side, x in (("right", 0.1), ("left", -0.1)):
        j[f"{side}_knee"] = (x, 0.0, 0.52)
        j[f"{side}_ankle"] = (x, -0.43 * np.sin(bend), 0.52 - 0.43 * np.cos(bend))  # a flexing shin swings back
    pose = np.zeros((17, 3))
    for name, xyz in j.items():
        pose[JOINT_INDEX[name]] = xyz
    return np.repeat(pose[None], frames, axis=0)
