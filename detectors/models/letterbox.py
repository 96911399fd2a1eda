"""Letterbox resizing (keep aspect, pad) and its inverse for keypoints; pure functions over arrays."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Letterbox:
    """How an image was placed in a model input: ``input_xy = image_xy * scale + offset`` (per axis x, y)."""

    scale: tuple[float, float]
    offset: tuple[float, float]
    input_size: tuple[int, int]  # (height, width) of the model input

    def to_image(self, xy: np.ndarray) -> np.ndarray:
        """Model-input pixel coordinates ``(..., 2)`` -> original image pixels."""
        return (np.asarray(xy, dtype=np.float64) - np.asarray(self.offset)) / np.asarray(self.scale)


def letterbox(
    image: np.ndarray,
    input_size: tuple[int, int],
    pad_value: int = 0,
    center: bool = False,
    box_filter: bool = False,
) -> tuple[np.ndarray, Letterbox]:
    """Resize ``image`` (H, W, C) to fit ``input_size`` (h, w) keeping its aspect, padded; -> (h, w, C), placement.

    The image sits at the top-left corner, or in the middle with ``center``. Shrinking averages
    the pixels each output pixel covers (``INTER_AREA``), or with ``box_filter`` blurs by a box of
    the shrink factor and samples bilinearly (:func:`box_downscale`: nearly the same image, about
    ten times faster for large factors).
    """
    import cv2

    height, width = image.shape[:2]
    in_h, in_w = input_size
    scale = min(in_h / height, in_w / width)
    new_h, new_w = max(1, round(height * scale)), max(1, round(width * scale))
    if scale < 1 and box_filter:
        resized = box_downscale(image, (new_h, new_w))
    else:
        resized = cv2.resize(image, (new_w, new_h), interpolation=cv2.INTER_AREA if scale < 1 else cv2.INTER_LINEAR)
    top, left = ((in_h - new_h) // 2, (in_w - new_w) // 2) if center else (0, 0)
    padded = np.full((in_h, in_w, image.shape[2]), pad_value, dtype=image.dtype)
    padded[top : top + new_h, left : left + new_w] = resized
    axis_scale = (new_w / width, new_h / height)
    placement = Letterbox(scale=axis_scale, offset=(float(left), float(top)), input_size=(in_h, in_w))
    return padded, placement


def box_downscale(image: np.ndarray, size: tuple[int, int]) -> np.ndarray:
    """``image`` (H, W, C) shrunk to ``size`` (h, w): a box blur as wide as the shrink factor (rounded), then
    bilinear sampling. Close to ``INTER_AREA``, whose general (non-integer factor) path costs ~10x more."""
    import cv2

    factor = round(min(image.shape[0] / size[0], image.shape[1] / size[1]))
    blurred = cv2.blur(image, (factor, factor)) if factor >= 2 else image
    return cv2.resize(blurred, (size[1], size[0]), interpolation=cv2.INTER_LINEAR)


def fit_size(image_size: tuple[int, int], longest: int, multiple: int) -> tuple[int, int]:
    """Input (h, w) whose longer side is ``longest`` and both sides multiples of ``multiple``, keeping aspect."""
    height, width = image_size
    scale = longest / max(height, width)

    def _round_up(value: float) -> int:
        return max(multiple, int(np.ceil(value / multiple)) * multiple)

    return _round_up(height * scale), _round_up(width * scale)
