"""Ultralytics YOLO-pose export: RGB/255 ``[1, 3, H, W]`` (centred letterbox, grey 114) -> ``[1, 5 + 3K, N]``.

Each of the N candidates is cx, cy, w, h, score, then K keypoints (x, y,
visibility) in input pixels; non-maximum suppression runs here.
"""

from __future__ import annotations

import numpy as np

from platypose.detectors.keypoints import model_layout
from platypose.detectors.models.boxes import center_to_corners, nms
from platypose.detectors.models.letterbox import letterbox
from platypose.detectors.models.onnx_io import input_hw, to_nchw


class YoloPose:
    """Runner for a YOLO-pose session."""

    def __init__(self, session, min_score: float = 0.25, iou: float = 0.7) -> None:
        channels = session.get_outputs()[0].shape[1]
        if not isinstance(channels, int) or (channels - 5) % 3:
            raise ValueError(f"output channels {channels} are not 5 + 3K")
        self.session = session
        self.layout = model_layout((channels - 5) // 3)
        self.input_size = input_hw(session, (640, 640))
        self.min_score, self.iou = min_score, iou
        self.name = f"yolo-pose:{session.get_inputs()[0].name}@{self.input_size[0]}x{self.input_size[1]}"

    def __call__(self, image: np.ndarray) -> np.ndarray:
        """BGR image (H, W, 3) -> people (N, K, 3) as x_px, y_px, confidence."""
        import cv2

        padded, placement = letterbox(cv2.cvtColor(image, cv2.COLOR_BGR2RGB), self.input_size, 114, center=True)
        raw = self.session.run(None, {self.session.get_inputs()[0].name: to_nchw(padded, 0.0, 255.0)})[0]
        return decode_yolo_pose(raw[0].T, placement, self.min_score, self.iou)


def decode_yolo_pose(candidates: np.ndarray, placement, min_score: float, iou: float) -> np.ndarray:
    """Candidates (N, 5 + 3K) in input pixels -> people (M, K, 3) in image pixels after NMS."""
    keep = nms(center_to_corners(candidates[:, :4]), candidates[:, 4], iou, min_score)
    keypoints = candidates[keep, 5:].reshape(len(keep), (candidates.shape[1] - 5) // 3, 3)
    return np.concatenate([placement.to_image(keypoints[..., :2]), keypoints[..., 2:3]], axis=-1)
