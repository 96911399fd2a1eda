"""Plausibility checks on a loaded clip, so a broken file never reaches training or evaluation.

A clip is refused (InputError naming the file and the first bad frame) when a
joint is infinite, lies farther than ``MAX_DISTANCE_M`` from the origin, or a
bone is longer than ``MAX_BONE_M`` (a corrupt value, or a file in another unit
than it says). NaN stays allowed: it marks a joint the file does not have.
"""

from __future__ import annotations

import numpy as np

from platypose.lifting.errors import InputError
from platypose.lifting.motion import Motion
from platypose.lifting.skeleton import BONES, JOINT_NAMES

MAX_DISTANCE_M = 1000.0
MAX_BONE_M = 2.0


def check_motion(motion: Motion, source: str) -> None:
    """InputError naming ``source`` and the first frame where ``motion`` is infinite or implausibly large."""
    joints = motion.joints
    with np.errstate(invalid="ignore", over="ignore"):
        bad = np.isinf(joints).any(axis=(1, 2)) | (np.abs(joints) > MAX_DISTANCE_M).any(axis=(1, 2))
        if bad.any():
            frame = int(np.argmax(bad))
            worst = float(np.nanmax(np.abs(joints[frame])))
            raise InputError(
                f"{source}: frame {frame} of {motion.name} has a joint {worst:.3g} m from the origin "
                f"(more than {MAX_DISTANCE_M:g} m: a corrupt value or wrong units)"
            )
        child = [c for c, _ in BONES]
        parent = [p for _, p in BONES]
        lengths = np.linalg.norm(joints[:, child] - joints[:, parent], axis=-1)  # (T, 16), NaN where missing
        long = np.nan_to_num(lengths, nan=0.0) > MAX_BONE_M
    if long.any():
        frame, bone = (int(v[0]) for v in np.nonzero(long))
        c, p = BONES[bone]
        raise InputError(
            f"{source}: frame {frame} of {motion.name}: bone {JOINT_NAMES[p]}-{JOINT_NAMES[c]} is "
            f"{lengths[frame, bone]:.3g} m long (more than {MAX_BONE_M:g} m: a corrupt value or wrong units)"
        )
