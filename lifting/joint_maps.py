"""How each of our 17 joints is obtained from every other skeleton, written once.

A recipe maps each of our joint names to a weighted average of named source
points (weights sum to 1). 2D keypoint sets and 3D mocap skeletons use the same
machinery so that a joint means the same point in 2D and in 3D (see the joint
meanings in :mod:`lifting.skeleton`).

Confidence of a synthesised joint (one made from several source points) is
the minimum of the confidences of the points it is made from: a joint is only
as certain as its least certain ingredient.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence

import numpy as np

from lifting.skeleton import JOINT_NAMES

Recipe = Mapping[str, Mapping[str, float]]


def _mid(a: str, b: str) -> dict[str, float]:
    return {a: 0.5, b: 0.5}


COCO17_NAMES: tuple[str, ...] = (
    "nose", "left_eye", "right_eye", "left_ear", "right_ear",
    "left_shoulder", "right_shoulder", "left_elbow", "right_elbow",
    "left_wrist", "right_wrist", "left_hip", "right_hip",
    "left_knee", "right_knee", "left_ankle", "right_ankle",
)  # fmt: skip

# COCO-17 (MoveNet, YOLO-pose, RTMPose, MMPose body models) -> ours.
# neck (base of skull) is taken halfway between the shoulder midpoint and the
# ear midpoint; head (centre of the head) is the ear midpoint.
COCO17_RECIPE: Recipe = {
    "pelvis": _mid("left_hip", "right_hip"),
    "right_hip": {"right_hip": 1.0},
    "right_knee": {"right_knee": 1.0},
    "right_ankle": {"right_ankle": 1.0},
    "left_hip": {"left_hip": 1.0},
    "left_knee": {"left_knee": 1.0},
    "left_ankle": {"left_ankle": 1.0},
    "spine": {"left_hip": 0.25, "right_hip": 0.25, "left_shoulder": 0.25, "right_shoulder": 0.25},
    "thorax": _mid("left_shoulder", "right_shoulder"),
    "neck": {"left_shoulder": 0.25, "right_shoulder": 0.25, "left_ear": 0.25, "right_ear": 0.25},
    "head": _mid("left_ear", "right_ear"),
    "left_shoulder": {"left_shoulder": 1.0},
    "left_elbow": {"left_elbow": 1.0},
    "left_wrist": {"left_wrist": 1.0},
    "right_shoulder": {"right_shoulder": 1.0},
    "right_elbow": {"right_elbow": 1.0},
    "right_wrist": {"right_wrist": 1.0},
}


def recipe_matrix(recipe: Recipe, source_names: Sequence[str]) -> np.ndarray:
    """Weight matrix ``W`` (17, S) with ``ours = W @ source``; raises KeyError on an unknown source name."""
    index = {name: i for i, name in enumerate(source_names)}
    weights = np.zeros((len(JOINT_NAMES), len(source_names)))
    for j, joint in enumerate(JOINT_NAMES):
        for source, w in recipe[joint].items():
            if source not in index:
                raise KeyError(f"recipe for {joint!r} needs source point {source!r}, which the skeleton lacks")
            weights[j, index[source]] = w
    return weights


def apply_recipe(points: np.ndarray, source_names: Sequence[str], recipe: Recipe) -> np.ndarray:
    """Map source points ``(..., S, D)`` onto our joints ``(..., 17, D)`` by weighted averages."""
    weights = recipe_matrix(recipe, source_names)
    return np.einsum("js,...sd->...jd", weights, points)


def apply_recipe_with_confidence(
    points: np.ndarray, confidence: np.ndarray, source_names: Sequence[str], recipe: Recipe
) -> tuple[np.ndarray, np.ndarray]:
    """Map 2D keypoints ``(..., S, 2)`` with confidences ``(..., S)`` onto ours.

    Returns points ``(..., 17, 2)`` and confidences ``(..., 17)``, each joint's
    confidence being the minimum over the source points it is made from.
    """
    weights = recipe_matrix(recipe, source_names)
    mapped = np.einsum("js,...sd->...jd", weights, points)
    used = weights > 0
    conf = np.stack(
        [confidence[..., used[j]].min(axis=-1) for j in range(len(JOINT_NAMES))], axis=-1
    )
    return mapped, conf
