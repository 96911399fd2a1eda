"""Small helpers shared by the ONNX runners: static input sizes and image -> NCHW float tensors."""

from __future__ import annotations

import numpy as np


def input_hw(session, default: tuple[int, int]) -> tuple[int, int]:
    """(height, width) of an NCHW image input, ``default`` where the model leaves them dynamic."""
    shape = session.get_inputs()[0].shape
    height, width = shape[2], shape[3]
    return (height if isinstance(height, int) else default[0], width if isinstance(width, int) else default[1])


def to_nchw(image: np.ndarray, mean=0.0, std=1.0) -> np.ndarray:
    """Image (H, W, 3) -> float32 tensor (1, 3, H, W) of ``(image - mean) / std``."""
    tensor = (image.astype(np.float32) - np.asarray(mean, np.float32)) / np.asarray(std, np.float32)
    return np.ascontiguousarray(tensor.transpose(2, 0, 1)[None])


def outputs_by_rank(outputs: list[np.ndarray]) -> dict[int, np.ndarray]:
    """Model outputs keyed by their rank (for contracts whose outputs differ in rank)."""
    return {array.ndim: array for array in outputs}
