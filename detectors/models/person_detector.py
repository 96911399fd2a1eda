"""Person detectors for top-down pose models (``--person-detector``): image -> boxes (N, 4) x1 y1 x2 y2.

Contracts, recognised from the outputs:

- ``dets``: ``[1, N, 5]`` (x1 y1 x2 y2 score) [+ labels ``[1, N]``], NMS inside (mmdeploy YOLOX / RTMDet as in
  rtmlib); BGR 0-255 input, top-left letterbox, grey 114.
- ``yolox``: raw YOLOX ``[1, N, 5 + C]`` (grid offsets, log sizes, objectness, class scores); same input.
- ``yolo``: ultralytics YOLO detect ``[1, 4 + C, N]`` (cx cy w h, class scores); RGB/255, centred letterbox.

Class 0 is the person in all of them (COCO).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from platypose.detectors.models.boxes import center_to_corners, nms
from platypose.detectors.models.letterbox import letterbox
from platypose.detectors.models.onnx_io import input_hw, to_nchw
from platypose.detectors.models.session import open_session
from platypose.lifting.errors import InputError

_STRIDES = (8, 16, 32)


def yolox_grid(input_size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """YOLOX anchor grid: cell corners (N, 2) x, y and strides (N, 1), for strides 8, 16, 32."""
    cells, strides = [], []
    for stride in _STRIDES:
        ys, xs = np.mgrid[0 : input_size[0] // stride, 0 : input_size[1] // stride]
        cells.append(np.stack([xs.ravel(), ys.ravel()], axis=-1))
        strides.append(np.full((xs.size, 1), stride))
    return np.concatenate(cells).astype(np.float32), np.concatenate(strides).astype(np.float32)


def decode_yolox(raw: np.ndarray, input_size: tuple[int, int]) -> tuple[np.ndarray, np.ndarray]:
    """Raw YOLOX predictions (N, 5 + C) -> person boxes (N, 4) x1 y1 x2 y2 in input pixels and scores (N,)."""
    cells, strides = yolox_grid(input_size)
    if len(cells) != len(raw):
        raise ValueError(f"{len(raw)} predictions, but the YOLOX grid of a {input_size} input has {len(cells)}")
    centers = (raw[:, :2] + cells) * strides
    sizes = np.exp(raw[:, 2:4]) * strides
    return center_to_corners(np.concatenate([centers, sizes], axis=1)), raw[:, 4] * raw[:, 5]


class PersonDetector:
    """Runner for one of the person-detector contracts; keeps boxes with score >= ``min_score`` after NMS."""

    def __init__(self, session, min_score: float = 0.3, iou: float = 0.45) -> None:
        outputs = [o.shape for o in session.get_outputs()]
        first = outputs[0]
        rows, columns = (first[1], first[2]) if len(first) == 3 else (None, None)
        if columns == 5:
            self.contract = "dets"
        elif len(outputs) == 1 and isinstance(columns, int) and columns > 5 and (rows is None or rows > columns):
            self.contract = "yolox"  # [1, anchors, 5 + classes]
        elif len(outputs) == 1 and isinstance(rows, int) and rows > 4 and (columns is None or columns > rows):
            self.contract = "yolo"  # [1, 4 + classes, anchors]
        else:
            raise ValueError(f"outputs {outputs} match no person-detector contract (dets, yolox, yolo)")
        self.session = session
        self.input_size = input_hw(session, (640, 640))
        self.min_score, self.iou = min_score, iou

    def __call__(self, image: np.ndarray) -> np.ndarray:
        """BGR image (H, W, 3) -> person boxes (N, 4) x1 y1 x2 y2 in image pixels, best first."""
        import cv2

        name = self.session.get_inputs()[0].name
        if self.contract == "yolo":
            padded, placement = letterbox(cv2.cvtColor(image, cv2.COLOR_BGR2RGB), self.input_size, 114, center=True)
            raw = self.session.run(None, {name: to_nchw(padded, 0.0, 255.0)})[0][0].T
            boxes, scores = center_to_corners(raw[:, :4]), raw[:, 4]
        else:
            padded, placement = letterbox(image, self.input_size, 114)
            outputs = self.session.run(None, {name: to_nchw(padded)})
            if self.contract == "yolox":
                boxes, scores = decode_yolox(outputs[0][0], self.input_size)
            else:
                boxes, scores = outputs[0][0, :, :4], outputs[0][0, :, 4]
                if len(outputs) > 1:
                    scores = np.where(outputs[1].reshape(-1) == 0, scores, 0.0)
        keep = nms(boxes, scores, self.iou, self.min_score)
        corners = placement.to_image(boxes[keep].reshape(-1, 2, 2))
        return corners.reshape(-1, 4)


def load_person_detector(model: str | Path, threads: int | None, provider: str) -> PersonDetector:
    """A person detector for ``model``; InputError if its outputs match no person-detector contract."""
    session = open_session(model, threads, provider)
    try:
        return PersonDetector(session)
    except ValueError as err:
        raise InputError(f"{model}: not a known person detector ({err})") from None
