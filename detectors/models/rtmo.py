"""RTMO one-stage (as run by rtmlib): BGR 0-255 ``[1, 3, 640, 640]`` (top-left letterbox, grey 114) ->
dets ``[1, N, 5]`` (x1 y1 x2 y2 score) and keypoints ``[1, N, K, 3]`` (x, y, score), in input pixels.
"""

from __future__ import annotations

import numpy as np

from platypose.detectors.keypoints import model_layout
from platypose.detectors.models.boxes import nms
from platypose.detectors.models.letterbox import letterbox
from platypose.detectors.models.onnx_io import input_hw, outputs_by_rank, to_nchw


class RTMO:
    """Runner for an RTMO session; people below ``min_score`` are dropped, then NMS."""

    def __init__(self, session, min_score: float = 0.3, iou: float = 0.45) -> None:
        ranks = {len(o.shape): o for o in session.get_outputs()}
        if set(ranks) != {3, 4}:
            raise ValueError("expected dets [1, N, 5] and keypoints [1, N, K, 3]")
        self.session = session
        self.layout = model_layout(ranks[4].shape[2])
        self.input_size = input_hw(session, (640, 640))
        self.min_score, self.iou = min_score, iou
        self.name = f"rtmo@{self.input_size[0]}x{self.input_size[1]}"

    def __call__(self, image: np.ndarray) -> np.ndarray:
        """BGR image (H, W, 3) -> people (N, K, 3) as x_px, y_px, confidence."""
        padded, placement = letterbox(image, self.input_size, 114)
        outputs = self.session.run(None, {self.session.get_inputs()[0].name: to_nchw(padded)})
        by_rank = outputs_by_rank(outputs)
        dets, keypoints = by_rank[3][0], by_rank[4][0]
        keep = nms(dets[:, :4], dets[:, 4], self.iou, self.min_score)
        people = keypoints[keep]
        return np.concatenate([placement.to_image(people[..., :2]), people[..., 2:3]], axis=-1)
