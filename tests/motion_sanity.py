"""Plausibility checks for imported real motion, shared by the motion importer tests."""

from __future__ import annotations

import numpy as np

from platypose.lifting.motion import Motion
from platypose.lifting.skeleton import BONES, JOINT_INDEX, bone_lengths

# (child, parent) joint names -> plausible adult length range in metres.
LIMB_RANGES: dict[tuple[str, str], tuple[float, float]] = {
    ("right_knee", "right_hip"): (0.33, 0.52),
    ("left_knee", "left_hip"): (0.33, 0.52),
    ("right_ankle", "right_knee"): (0.32, 0.52),
    ("left_ankle", "left_knee"): (0.32, 0.52),
    ("right_hip", "pelvis"): (0.05, 0.15),
    ("left_hip", "pelvis"): (0.05, 0.15),
    ("left_elbow", "left_shoulder"): (0.22, 0.38),
    ("right_elbow", "right_shoulder"): (0.22, 0.38),
    ("left_wrist", "left_elbow"): (0.18, 0.33),
    ("right_wrist", "right_elbow"): (0.18, 0.33),
    ("left_shoulder", "thorax"): (0.1, 0.24),
    ("right_shoulder", "thorax"): (0.1, 0.24),
}
LIMB_BONES = [BONES.index((JOINT_INDEX[c], JOINT_INDEX[p])) for c, p in LIMB_RANGES]


def median_limb_lengths(motion: Motion) -> dict[tuple[str, str], float]:
    """Median length over time of each limb bone in LIMB_RANGES."""
    lengths = np.nanmedian(bone_lengths(motion.joints)[:, LIMB_BONES], axis=0)
    return dict(zip(LIMB_RANGES, lengths.tolist()))


def assert_plausible(motion: Motion, rigid_tol_m: float, min_head_rise_m: float = 0.2) -> None:
    """Limb lengths adult-sized, constant over time (std below ``rigid_tol_m``), head above pelvis on average (Z up)."""
    for bone, length in median_limb_lengths(motion).items():
        low, high = LIMB_RANGES[bone]
        assert low <= length <= high, f"{motion.name}: {bone} median length {length:.3f} m outside [{low}, {high}]"
    spread = np.nanstd(bone_lengths(motion.joints)[:, LIMB_BONES], axis=0)
    assert spread.max() < rigid_tol_m, f"{motion.name}: limb lengths vary by {spread.max() * 1000:.1f} mm"
    rise = np.nanmean(motion.joints[:, JOINT_INDEX["head"], 2] - motion.joints[:, JOINT_INDEX["pelvis"], 2])
    assert rise > min_head_rise_m, f"{motion.name}: head only {rise:.3f} m above pelvis on average"
    assert np.isfinite(motion.joints).all()


def facing_agrees_with_travel(motion: Motion) -> float:
    """Cosine between the mean facing direction (left hip - right hip) x up and the pelvis' net horizontal travel."""
    left = motion.joints[:, JOINT_INDEX["left_hip"]] - motion.joints[:, JOINT_INDEX["right_hip"]]
    facing = np.cross(left, [0.0, 0.0, 1.0]).mean(axis=0)[:2]
    travel = (motion.joints[-1, JOINT_INDEX["pelvis"]] - motion.joints[0, JOINT_INDEX["pelvis"]])[:2]
    return float(facing @ travel / (np.linalg.norm(facing) * np.linalg.norm(travel)))
