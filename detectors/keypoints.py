"""Map a detector's own keypoint layout onto our 17 joints, with missing points as NaN."""

from __future__ import annotations

import numpy as np

from platypose.lifting.joint_maps import KEYPOINT_LAYOUTS, apply_recipe_with_confidence

_LAYOUT_BY_COUNT = {17: "coco17", 26: "halpe26", 133: "wholebody133"}


def model_layout(num_keypoints: int | None) -> str:
    """Layout of a model's K keypoints: 17 COCO, 26 Halpe or 133 COCO-WholeBody (ValueError otherwise)."""
    if num_keypoints not in _LAYOUT_BY_COUNT:
        raise ValueError(
            f"{num_keypoints} keypoints per person match no known layout (17 COCO, 26 Halpe, 133 COCO-WholeBody)"
        )
    return _LAYOUT_BY_COUNT[num_keypoints]


def to_our_joints(points: np.ndarray, layout: str) -> np.ndarray:
    """Source keypoints ``(..., S, 3)`` (x, y, confidence) in ``layout`` -> ours ``(..., 17, 3)``.

    A source point with confidence 0 or a NaN coordinate is missing; a joint made
    from a missing point is missing (NaN, confidence 0). Confidences are clipped to [0, 1].
    """
    names, recipe = KEYPOINT_LAYOUTS[layout]
    points = np.asarray(points, dtype=np.float64)
    if points.shape[-2:] != (len(names), 3):
        raise ValueError(f"layout {layout} needs (..., {len(names)}, 3) keypoints, got {points.shape}")
    xy = points[..., :2]
    conf = np.clip(np.nan_to_num(points[..., 2], nan=0.0), 0.0, 1.0)
    conf = np.where(np.isfinite(xy).all(axis=-1), conf, 0.0)
    xy = np.where(conf[..., None] > 0, xy, 0.0)
    mapped, mapped_conf = apply_recipe_with_confidence(xy, conf, names, recipe)
    mapped = np.where(mapped_conf[..., None] > 0, mapped, np.nan)
    return np.concatenate([mapped, mapped_conf[..., None]], axis=-1)


def missing_persons(num_frames: int, num_persons: int) -> np.ndarray:
    """An all-missing keypoint array ``(T, P, 17, 3)``: NaN positions, confidence 0."""
    out = np.full((num_frames, num_persons, 17, 3), np.nan, dtype=np.float32)
    out[..., 2] = 0.0
    return out
