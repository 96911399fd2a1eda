"""Numbers that let a user check an imported clip: frames, rate, duration, body height, bone lengths."""

from __future__ import annotations

import numpy as np

from platypose.lifting.motion import Motion
from platypose.lifting.skeleton import BONES, JOINT_INDEX, JOINT_NAMES, bone_lengths

# Bones from ankle to head centre whose summed median lengths give the upright
# ankle-to-head-centre height; a tuple of several is averaged (left/right legs).
HEIGHT_CHAIN: tuple[tuple[str, ...], ...] = (
    ("left_knee-left_ankle", "right_knee-right_ankle"),
    ("left_hip-left_knee", "right_hip-right_knee"),
    ("pelvis-spine",),
    ("spine-thorax",),
    ("thorax-neck",),
    ("neck-head",),
)


def median_bone_lengths(joints: np.ndarray) -> dict[str, float]:
    """Median over time of each bone's length, ``(T, 17, 3) -> {"parent-child": metres}`` (NaN if never seen)."""
    lengths = bone_lengths(joints)
    medians = [float(np.nanmedian(col)) if np.isfinite(col).any() else float("nan") for col in lengths.T]
    return {f"{JOINT_NAMES[p]}-{JOINT_NAMES[c]}": m for (c, p), m in zip(BONES, medians)}


def skeleton_height(joints: np.ndarray) -> float:
    """Ankle-to-head-centre height of the skeleton stood upright, from median bone lengths, ``(T, 17, 3)`` -> metres."""
    medians = median_bone_lengths(joints)
    return float(sum(np.mean([medians[b] for b in bones]) for bones in HEIGHT_CHAIN))


def motion_summary(motion: Motion) -> dict:
    """Plain-data summary of a clip for ``platypose motion info``."""
    finite = np.isfinite(motion.joints).all(axis=-1)
    rise = motion.joints[:, JOINT_INDEX["head"], 2] - motion.joints[:, JOINT_INDEX["pelvis"], 2]
    return {
        "name": motion.name,
        "format": motion.extra.get("format", ""),
        "frames": motion.num_frames,
        "fps": motion.fps,
        "duration_s": motion.duration_s,
        "source": motion.source,
        "licence": motion.licence,
        "ankle_to_head_m": skeleton_height(motion.joints),
        "head_above_pelvis_m": float(np.nanmean(rise)) if np.isfinite(rise).any() else float("nan"),
        "missing_joints": [JOINT_NAMES[j] for j in range(len(JOINT_NAMES)) if not finite[:, j].any()],
        "bone_lengths_m": median_bone_lengths(motion.joints),
    }
