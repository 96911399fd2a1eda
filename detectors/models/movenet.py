"""MoveNet MultiPose (the bundled default): int32 RGB ``[1, H, W, 3]`` in, ``[1, 6, 56]`` out.

Each of the 6 rows is 17 COCO keypoints as (y, x, score) normalised to the
input, then a box (ymin, xmin, ymax, xmax, score). The frame is letterboxed so
its longer side is ``longest`` pixels and both sides are multiples of 32.
"""

from __future__ import annotations

import numpy as np

from platypose.detectors.models.letterbox import fit_size, letterbox

DEFAULT_LONGEST = 384  # input size of the longest side; why not 256: docs/keypoints.md


class MoveNetMultiPose:
    """Runner for a MoveNet MultiPose ONNX session; people below ``min_score`` (box score) are dropped."""

    layout = "coco17"

    def __init__(self, session, longest: int = DEFAULT_LONGEST, min_score: float = 0.2) -> None:
        inputs, outputs = session.get_inputs(), session.get_outputs()
        if len(inputs[0].shape) != 4 or inputs[0].shape[3] != 3 or outputs[0].shape[-1] != 56:
            raise ValueError("expected an NHWC image input and a [1, 6, 56] output")
        self.session = session
        self.input_name = session.get_inputs()[0].name
        self.longest = longest
        self.min_score = min_score
        self.name = f"movenet-multipose@{longest}-box"  # the box-filter letterbox; caches of INTER_AREA runs are stale

    def __call__(self, image: np.ndarray) -> np.ndarray:
        """BGR image (H, W, 3) -> people (N, 17, 3) as x_px, y_px, confidence."""
        import cv2

        size = fit_size(image.shape[:2], self.longest, 32)
        padded, placement = letterbox(image, size, box_filter=True)  # colours swapped after shrinking: fewer pixels
        rgb = cv2.cvtColor(padded, cv2.COLOR_BGR2RGB)
        rows = self.session.run(None, {self.input_name: rgb[None].astype(np.int32)})[0][0]
        return decode_movenet(rows, placement, self.min_score)


def decode_movenet(rows: np.ndarray, placement, min_score: float) -> np.ndarray:
    """MoveNet output rows (K, 56) -> people (N, 17, 3) in image pixels, keeping rows with box score >= min_score."""
    rows = rows[rows[:, 55] >= min_score]
    keypoints = rows[:, :51].reshape(-1, 17, 3)
    in_h, in_w = placement.input_size
    xy = placement.to_image(keypoints[..., [1, 0]] * np.array([in_w, in_h]))
    return np.concatenate([xy, keypoints[..., 2:3]], axis=-1)
