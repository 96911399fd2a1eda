"""Top-down pose models: a person detector finds boxes, the pose model reads one crop per box.

Crops follow rtmlib: the box enlarged 1.25 times and widened to the input's
aspect, warped to the input, ``(BGR - mean) / std`` with ImageNet mean and std.
Decoders: ``rtmpose`` SimCC (argmax of each 1D distribution divided by the split
ratio; score is the smaller maximum) and ``heatmap`` (argmax, quarter-pixel
shift towards the higher neighbour, maximum as score; heatmap corners map to
input corners as in UDP).
"""

from __future__ import annotations

import numpy as np

from platypose.detectors.keypoints import model_layout
from platypose.detectors.models.boxes import crop_for_box
from platypose.detectors.models.onnx_io import input_hw, to_nchw

MEAN = (123.675, 116.28, 103.53)
STD = (58.395, 57.12, 57.375)


def decode_simcc(simcc_x: np.ndarray, simcc_y: np.ndarray, input_size: tuple[int, int]) -> np.ndarray:
    """SimCC (K, Wx), (K, Wy) -> keypoints (K, 3) x, y in input pixels and score."""
    x = np.argmax(simcc_x, axis=1) * input_size[1] / simcc_x.shape[1]
    y = np.argmax(simcc_y, axis=1) * input_size[0] / simcc_y.shape[1]
    score = np.minimum(simcc_x.max(axis=1), simcc_y.max(axis=1))
    return np.stack([x, y, score], axis=-1)


def decode_heatmaps(heatmaps: np.ndarray, input_size: tuple[int, int]) -> np.ndarray:
    """Heatmaps (K, H, W) -> keypoints (K, 3) x, y in input pixels and score (the peak value)."""
    count, height, width = heatmaps.shape
    flat = heatmaps.reshape(count, -1)
    peak = np.argmax(flat, axis=1)
    ys, xs = np.divmod(peak, width)
    padded = np.pad(heatmaps, ((0, 0), (1, 1), (1, 1)), mode="edge")
    rows = np.arange(count)
    dx = padded[rows, ys + 1, xs + 2] - padded[rows, ys + 1, xs]
    dy = padded[rows, ys + 2, xs + 1] - padded[rows, ys, xs + 1]
    x = (xs + 0.25 * np.sign(dx)) * (input_size[1] - 1) / max(width - 1, 1)
    y = (ys + 0.25 * np.sign(dy)) * (input_size[0] - 1) / max(height - 1, 1)
    return np.stack([x, y, flat[rows, peak]], axis=-1)


class TopDown:
    """Runner for a top-down pose session (``rtmpose`` or ``heatmap``) with a person detector."""

    def __init__(self, session, format: str, person_detector) -> None:
        outputs = [o.shape for o in session.get_outputs()]
        self.session = session
        self.format = format
        self.num_keypoints = outputs[0][1]
        self.layout = model_layout(self.num_keypoints)
        self.input_size = input_hw(session, (256, 192))
        self.person_detector = person_detector
        self.name = f"{format}@{self.input_size[0]}x{self.input_size[1]}+persons@{person_detector.input_size[0]}"

    def __call__(self, image: np.ndarray) -> np.ndarray:
        """BGR image (H, W, 3) -> people (N, K, 3) as x_px, y_px, confidence, one per person box."""
        import cv2

        name = self.session.get_inputs()[0].name
        people = []
        for box in self.person_detector(image):
            crop = crop_for_box(box, self.input_size)
            patch = cv2.warpAffine(image, crop.matrix(), self.input_size[::-1], flags=cv2.INTER_LINEAR)
            outputs = self.session.run(None, {name: to_nchw(patch, MEAN, STD)})
            if self.format == "rtmpose":
                keypoints = decode_simcc(outputs[0][0], outputs[1][0], self.input_size)
            else:
                keypoints = decode_heatmaps(outputs[0][0], self.input_size)
            people.append(np.concatenate([crop.to_image(keypoints[:, :2]), keypoints[:, 2:]], axis=-1))
        return np.stack(people) if people else np.zeros((0, self.num_keypoints, 3))
