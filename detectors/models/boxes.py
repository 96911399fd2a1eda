"""Box maths for detectors: non-maximum suppression and the top-down crop around a person box."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


def nms(boxes: np.ndarray, scores: np.ndarray, iou: float, min_score: float) -> np.ndarray:
    """Indices kept by non-maximum suppression, best first; boxes (N, 4) x1 y1 x2 y2, scores (N,)."""
    import cv2

    if len(boxes) == 0:
        return np.zeros(0, dtype=np.int64)
    xywh = np.concatenate([boxes[:, :2], boxes[:, 2:] - boxes[:, :2]], axis=1)
    keep = cv2.dnn.NMSBoxes(xywh.tolist(), scores.astype(float).tolist(), min_score, iou)
    return np.asarray(keep, dtype=np.int64).reshape(-1)


def center_to_corners(boxes: np.ndarray) -> np.ndarray:
    """Boxes (..., 4) cx cy w h -> x1 y1 x2 y2."""
    half = boxes[..., 2:4] / 2
    return np.concatenate([boxes[..., :2] - half, boxes[..., :2] + half], axis=-1)


@dataclass(frozen=True)
class Crop:
    """A person box scaled into a model input: ``input_xy = (image_xy - center) * scale + input_wh / 2``."""

    center: tuple[float, float]
    scale: float
    input_size: tuple[int, int]  # (height, width)

    def matrix(self) -> np.ndarray:
        """The 2x3 affine matrix image -> model input, for ``cv2.warpAffine``."""
        in_h, in_w = self.input_size
        cx, cy = self.center
        return np.array([[self.scale, 0.0, in_w / 2 - self.scale * cx], [0.0, self.scale, in_h / 2 - self.scale * cy]])

    def to_image(self, xy: np.ndarray) -> np.ndarray:
        """Model-input coordinates (..., 2) -> image pixels."""
        in_h, in_w = self.input_size
        return (np.asarray(xy, dtype=np.float64) - np.array([in_w / 2, in_h / 2])) / self.scale + np.array(self.center)


def crop_for_box(box: np.ndarray, input_size: tuple[int, int], padding: float = 1.25) -> Crop:
    """The crop around box (4,) x1 y1 x2 y2, enlarged by ``padding`` and widened to the input's aspect."""
    in_h, in_w = input_size
    x1, y1, x2, y2 = (float(v) for v in box)
    width, height = (x2 - x1) * padding, (y2 - y1) * padding
    width, height = max(width, height * in_w / in_h), max(height, width * in_h / in_w)
    return Crop(center=((x1 + x2) / 2, (y1 + y2) / 2), scale=in_w / max(width, 1e-6), input_size=input_size)
