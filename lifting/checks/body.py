"""Is a person's median motion a human body? Its limb bones against human lengths, its joints against human range.

- **Bone lengths**: each limb bone's median length over the clip (thigh, shin, upper arm, forearm) inside the range
  of statures ``STATURE_RANGE_M`` (children to tall adults) by Drillis & Contini's segment fractions
  (:mod:`lifting.anatomy.lengths`), widened by ``LENGTH_MARGIN``; and each bone within ``MIRROR_RATIO`` of its mirror
  image. One view cannot measure a bone (its limbs are held to adult lengths, their asymmetry is the prior's guess),
  so :func:`lifting.checks.plausibility.body_plausibility` checks bones only where several views measured them.
- **Joint angles**: per frame, knee and elbow flexion (180 degrees less the angle the joint's two bones make) and
  hip flexion (180 degrees less the angle between the trunk, pelvis to thorax, and the thigh), each at most its
  ``FLEXION_LIMITS_DEG`` (tissue stops a knee or elbow folding flat, a thigh from passing through the trunk), and
  knee hyperextension (the shin bent forwards about the hips' axis) at most ``KNEE_HYPEREXTENSION_DEG``. A joint is
  out of range when more than ``ANGLE_SHARE`` of the frames the person is present put it there.
- **Hinge jumps**: the signed knee and elbow flexion the angles CSV and ``.mot`` carry (:mod:`lifting.anatomy.hinges`)
  changing faster than ``HINGE_SPEED_DEG_S`` between two frames the person is present in (a throwing elbow peaks
  near 2,500 degrees per second; walking and balancing stay far below): the frames, whatever made them.
"""

from __future__ import annotations

import numpy as np

from platypose.lifting.anatomy.hinges import HINGE_NAMES, signed_flexion
from platypose.lifting.anatomy.lengths import DEFINITION_MARGIN, SEGMENT_FRACTIONS
from platypose.lifting.skeleton import BONES, JOINT_INDEX, JOINT_NAMES, MIRROR

STATURE_RANGE_M = (1.0, 2.1)  # children of about 5 years to tall adults
LENGTH_MARGIN = DEFINITION_MARGIN  # joint centres sit off the table's landmarks
MIRROR_RATIO = 1.25  # longest over shortest of a limb bone and its mirror image
FLEXION_LIMITS_DEG = {"knee": 170.0, "elbow": 170.0, "hip": 165.0}
KNEE_HYPEREXTENSION_DEG = 30.0
HINGE_SPEED_DEG_S = 1800.0
ANGLE_SHARE = 0.05  # share of present frames a joint may spend out of range (a few bad frames are noise)

_SIDES = ("right", "left")


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Angle in degrees between vectors ``(..., 3)``."""
    cos = (a * b).sum(-1) / (np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1))
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def joint_flexions(joints: np.ndarray) -> dict[str, np.ndarray]:
    """Per frame flexion angles (degrees, ``(T,)``) of motion ``(T, 17, 3)``: ``"<side> knee"``, ``"<side> elbow"``,
    ``"<side> hip"`` and ``"<side> knee hyperextension"`` (positive when the shin bends forwards)."""
    j = {name: joints[:, i] for name, i in JOINT_INDEX.items()}
    trunk = j["thorax"] - j["pelvis"]
    right = j["right_hip"] - j["left_hip"]
    angles = {}
    for side in _SIDES:
        thigh, shin = j[f"{side}_knee"] - j[f"{side}_hip"], j[f"{side}_ankle"] - j[f"{side}_knee"]
        upper, fore = j[f"{side}_elbow"] - j[f"{side}_shoulder"], j[f"{side}_wrist"] - j[f"{side}_elbow"]
        angles[f"{side} knee"] = _angle(thigh, shin)
        angles[f"{side} elbow"] = _angle(upper, fore)
        angles[f"{side} hip"] = _angle(trunk, -thigh)
        # the shin turning about the hips' axis away from a flexing knee's direction (cross(thigh, shin) . right > 0)
        bend = np.einsum("...i,...i->...", np.cross(thigh, shin), right / np.linalg.norm(right, axis=-1)[:, None])
        sine = bend / (np.linalg.norm(thigh, axis=-1) * np.linalg.norm(shin, axis=-1))
        angles[f"{side} knee hyperextension"] = np.degrees(np.arcsin(np.clip(sine, -1.0, 1.0)))
    return angles


def _limit(name: str) -> float:
    """The most a joint angle of :func:`joint_flexions` may be."""
    if name.endswith("hyperextension"):
        return KNEE_HYPEREXTENSION_DEG
    return FLEXION_LIMITS_DEG[name.split()[1]]


def angles_out_of_range(joints: np.ndarray) -> dict[str, dict]:
    """Joints of motion ``(T, 17, 3)`` (NaN where absent) past their limit in more than ``ANGLE_SHARE`` of the
    present frames: name -> ``{"limit_deg", "share", "max_deg"}``."""
    present = np.isfinite(joints).all(axis=(1, 2))
    if not present.any():
        return {}
    out = {}
    with np.errstate(invalid="ignore", divide="ignore"):
        for name, angle in joint_flexions(np.asarray(joints, np.float64)[present]).items():
            limit = _limit(name)
            share = float(np.mean(angle > limit))
            if share > ANGLE_SHARE:
                out[name] = {"limit_deg": limit, "share": round(share, 3), "max_deg": round(float(np.nanmax(angle)), 1)}
    return out


def hinge_jumps(joints: np.ndarray, fps: float) -> dict[str, dict]:
    """Hinges of motion ``(T, 17, 3)`` at ``fps`` (NaN where absent) whose signed flexion changes faster than
    ``HINGE_SPEED_DEG_S`` between consecutive present frames: name (``"right elbow"``) -> ``{"frames"`` (the later
    frame of each such pair), ``"max_deg_per_s"}``."""
    with np.errstate(invalid="ignore"):
        speed = np.abs(np.diff(signed_flexion(np.asarray(joints, np.float64)), axis=0)) * fps  # (T - 1, 4), NaN: absent
    out = {}
    for name, rate in zip(HINGE_NAMES, speed.T):
        fast = np.flatnonzero(rate > HINGE_SPEED_DEG_S)
        if fast.size:
            out[name.replace("_", " ")] = {
                "frames": (fast + 1).tolist(),
                "max_deg_per_s": round(float(rate[fast].max())),
            }
    return out


def _bone_name(bone: int) -> str:
    child, parent = BONES[bone]
    return f"{JOINT_NAMES[parent]}-{JOINT_NAMES[child]}".replace("_", " ")


def bone_lengths_out_of_range(joints: np.ndarray) -> dict[str, dict]:
    """Limb bones of motion ``(T, 17, 3)`` (NaN where absent) whose median length lies outside human lengths, or
    more than ``MIRROR_RATIO`` from their mirror image's: bone name (``"right hip-right knee"``) -> ``{"length_m",
    "range_m"}``."""
    low, high = STATURE_RANGE_M
    present = np.isfinite(joints).all(axis=(1, 2))
    if not present.any():
        return {}
    joints = np.asarray(joints, np.float64)[present]
    lengths = {
        BONES.index((JOINT_INDEX[c], JOINT_INDEX[p])): (
            float(np.median(np.linalg.norm(joints[:, JOINT_INDEX[c]] - joints[:, JOINT_INDEX[p]], axis=-1))),
            (fraction * low * (1 - LENGTH_MARGIN), fraction * high * (1 + LENGTH_MARGIN)),
        )
        for (c, p), fraction in SEGMENT_FRACTIONS.items()
    }
    out = {}
    for bone, (length, (shortest, longest)) in lengths.items():
        child, parent = BONES[bone]
        mirror = lengths[BONES.index((MIRROR[child], MIRROR[parent]))][0]
        if not shortest <= length <= longest or max(length, mirror) > MIRROR_RATIO * min(length, mirror):
            out[_bone_name(bone)] = {"length_m": round(length, 3), "range_m": [round(shortest, 3), round(longest, 3)]}
    return out
