"""A person's rigid shape: one length per bone and one shape per rigid body, measured once over a clip.

A body (:data:`lifting.skeleton.BODIES`: the pelvis with its hips and the spine, the thorax with its
shoulders and neck) moves its three children together, as a BVH skeleton does with one rotation per
joint: its shape is the three children's offsets from the body joint in the body's own frame
(x from the right child to the left one, y towards the midline child, z forward), the median over the
clip's frames. Every other bone has its median length. :func:`rebuild` puts a motion back together
from the pelvis, the bodies' rotations and the other bones' directions.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

from platypose.lifting.rotations import two_vector_frame
from platypose.lifting.skeleton import BODIES, BONES, PARENTS, bone_lengths

BODY_JOINTS: tuple[int, ...] = tuple(BODIES)
# Bones (into BONES) whose child belongs to a body: their direction comes with the body's rotation.
BODY_BONES: tuple[int, ...] = tuple(b for b, (_, parent) in enumerate(BONES) if parent in BODIES)


class RigidShape(NamedTuple):
    """``lengths`` (..., 16) metres in BONES order; ``bodies`` (..., B, 3, 3): per body of BODIES, its
    (left, right, midline) children's offsets from the body joint in the body's frame."""

    lengths: np.ndarray
    bodies: np.ndarray

    def rows(self, index) -> RigidShape:
        """The shape of the motions picked by ``index`` along the leading axes."""
        return RigidShape(self.lengths[index], self.bodies[index])


def body_offsets(joints: np.ndarray) -> np.ndarray:
    """Each body's (left, right, midline) children minus the body joint, world axes: ``(..., 17, 3) -> (..., B, 3, 3)``."""
    return np.stack([joints[..., list(kids), :] - joints[..., j, None, :] for j, kids in BODIES.items()], axis=-3)


def body_frames(offsets: np.ndarray) -> np.ndarray:
    """Each body's own frame (columns x, y, z in world axes) from its children's offsets ``(..., B, 3, 3)``."""
    return two_vector_frame(offsets[..., 0, :] - offsets[..., 1, :], offsets[..., 2, :])


def clip_shape(joints: np.ndarray) -> RigidShape:
    """The rigid shape of motions ``(..., T, 17, 3)``: medians over the present (finite) frames; NaN if none."""
    joints = np.asarray(joints, np.float64)
    offsets = body_offsets(joints)  # (..., T, B, 3, 3)
    local = np.einsum("...bji,...bkj->...bki", body_frames(offsets), offsets)
    if not np.isfinite(local).any():
        nan = np.full(joints.shape[:-3], np.nan)
        return RigidShape(
            nan[..., None] * np.ones(len(BONES)), nan[..., None, None, None] * np.ones((len(BODIES), 3, 3))
        )
    bodies = np.nanmedian(local, axis=-4)
    lengths = np.nanmedian(bone_lengths(joints), axis=-2)
    for b in BODY_BONES:  # a body's bones are as long as its shape says
        child, parent = BONES[b]
        lengths[..., b] = np.linalg.norm(
            bodies[..., BODY_JOINTS.index(parent), BODIES[parent].index(child), :], axis=-1
        )
    return RigidShape(lengths, bodies)


def rebuild(pelvis: np.ndarray, shape: RigidShape, rotations: np.ndarray, directions: np.ndarray) -> np.ndarray:
    """Joints ``(..., 17, 3)`` from the pelvis ``(..., 3)``, the bodies' ``rotations`` ``(..., B, 3, 3)`` (body frame
    to world) and unit ``directions`` ``(..., 16, 3)`` of the other bones (those of bodies are not read)."""
    joints = np.zeros(pelvis.shape[:-1] + (len(PARENTS), 3))
    joints[..., 0, :] = pelvis
    for b, (child, parent) in enumerate(BONES):  # parents come before their children
        if parent in BODIES:
            body = BODY_JOINTS.index(parent)
            offset = np.einsum(
                "...ij,...j->...i", rotations[..., body, :, :], shape.bodies[..., body, BODIES[parent].index(child), :]
            )
        else:
            offset = shape.lengths[..., b, None] * directions[..., b, :]
        joints[..., child, :] = joints[..., parent, :] + offset
    return joints
