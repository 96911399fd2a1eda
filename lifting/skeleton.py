"""The 17-joint skeleton every part of platypose agrees on (Human3.6M order).

Units are metres, the world is right-handed with Z up. Other skeletons (2D
keypoint sets, mocap hierarchies) are mapped onto these joints by the recipes
in :mod:`lifting.joint_maps`, which is the one place that says how each joint
is obtained from each source.

Joint meanings (what a recipe must produce):

- ``pelvis``: midpoint of the two hip joint centres.
- hips, knees, ankles: joint centres.
- ``spine``: mid torso, halfway between pelvis and thorax.
- ``thorax``: midpoint of the two shoulder joint centres.
- ``neck``: top of the neck / base of the skull (where the head pivots).
- ``head``: centre of the head (midpoint of the ears).
- shoulders, elbows, wrists: joint centres.
"""

from __future__ import annotations

import numpy as np

JOINT_NAMES: tuple[str, ...] = (
    "pelvis",
    "right_hip",
    "right_knee",
    "right_ankle",
    "left_hip",
    "left_knee",
    "left_ankle",
    "spine",
    "thorax",
    "neck",
    "head",
    "left_shoulder",
    "left_elbow",
    "left_wrist",
    "right_shoulder",
    "right_elbow",
    "right_wrist",
)
NUM_JOINTS = len(JOINT_NAMES)
JOINT_INDEX: dict[str, int] = {name: i for i, name in enumerate(JOINT_NAMES)}

# Parent of each joint in the kinematic tree; the pelvis (root) has -1.
PARENTS: tuple[int, ...] = (-1, 0, 1, 2, 0, 4, 5, 0, 7, 8, 9, 8, 11, 12, 8, 14, 15)

# Bones as (child, parent) pairs, in joint order.
BONES: tuple[tuple[int, int], ...] = tuple((j, p) for j, p in enumerate(PARENTS) if p >= 0)

# Index of each joint's mirror image (left <-> right), identity on the midline.
MIRROR: tuple[int, ...] = (0, 4, 5, 6, 1, 2, 3, 7, 8, 9, 10, 14, 15, 16, 11, 12, 13)

# Pairs of bone indices (into BONES) that are left/right mirror images.
SYMMETRIC_BONES: tuple[tuple[int, int], ...] = tuple(
    (b, BONES.index((MIRROR[c], MIRROR[p]))) for b, (c, p) in enumerate(BONES) if MIRROR[c] > c
)

ROOT = 0

# Joints with several children, which move their children as one rigid body (a pelvis carries its hips and the
# spine, a thorax its shoulders and neck): joint -> (left child, right child, midline child).
BODIES: dict[int, tuple[int, int, int]] = {
    JOINT_INDEX["pelvis"]: (JOINT_INDEX["left_hip"], JOINT_INDEX["right_hip"], JOINT_INDEX["spine"]),
    JOINT_INDEX["thorax"]: (JOINT_INDEX["left_shoulder"], JOINT_INDEX["right_shoulder"], JOINT_INDEX["neck"]),
}

# Median adult bone lengths (m) of the bundled real mocap (holosoma, DeepMimic, CMU,
# mocapbank; medians per clip, then across clips), in BONES order.
TYPICAL_BONE_LENGTHS: tuple[float, ...] = (
    0.085,
    0.422,
    0.410,
    0.085,
    0.422,
    0.410,
    0.240,
    0.240,
    0.116,
    0.050,
    0.183,
    0.275,
    0.259,
    0.183,
    0.275,
    0.259,
)

# Root-mean-square acceleration of every joint (m per frame squared at 30 fps, per axis) over the bundled
# real mocap resampled to 30 fps (holosoma, DeepMimic, CMU, mocapbank), in JOINT_NAMES order.
TYPICAL_ACCELERATIONS: tuple[float, ...] = (
    0.0039,
    0.0039,
    0.0064,
    0.0103,
    0.0040,
    0.0060,
    0.0086,
    0.0036,
    0.0044,
    0.0050,
    0.0053,
    0.0048,
    0.0068,
    0.0100,
    0.0048,
    0.0071,
    0.0106,
)

# Bones whose lengths measure a person's size the same way in every source (legs,
# arms, trunk); the neck and head segments depend on how each source places them.
SIZE_BONES: tuple[int, ...] = tuple(
    b for b, (c, _) in enumerate(BONES) if JOINT_NAMES[c] not in ("neck", "head", "right_hip", "left_hip")
)


def bone_vectors(joints):
    """Bone vectors child - parent, ``(..., 17, 3) -> (..., 16, 3)`` (numpy arrays or torch tensors)."""
    child = [c for c, _ in BONES]
    parent = [p for _, p in BONES]
    return joints[..., child, :] - joints[..., parent, :]


def bone_lengths(joints: np.ndarray) -> np.ndarray:
    """Bone lengths, ``(..., 17, 3) -> (..., 16)``."""
    return np.linalg.norm(bone_vectors(joints), axis=-1)


def mirror_joints(joints: np.ndarray) -> np.ndarray:
    """Mirror a motion through the world XZ plane (y -> -y) and swap left/right, ``(..., 17, 3)``."""
    mirrored = joints[..., list(MIRROR), :].copy()
    mirrored[..., 1] *= -1.0
    return mirrored
