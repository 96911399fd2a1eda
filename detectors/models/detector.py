"""The one interface every 2D keypoint detector implements."""

from __future__ import annotations

from typing import Protocol

import numpy as np


class Detector(Protocol):
    """Finds people in one image: ``detector(image_bgr (H, W, 3) uint8) -> (N, S, 3)`` x_px, y_px, confidence.

    ``layout`` names the S keypoints (a key of ``lifting.joint_maps.KEYPOINT_LAYOUTS``);
    ``name`` says which model and contract, for provenance and caching.
    """

    name: str
    layout: str

    def __call__(self, image: np.ndarray) -> np.ndarray: ...
