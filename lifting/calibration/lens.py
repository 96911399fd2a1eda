"""The focal length of an uncalibrated video where its people cannot measure it: the lens its metadata names, else a
prior over common lenses.

- **Metadata**: phones often write the lens as a 35 mm-equivalent focal length (a tag whose name holds ``35mm``).
  35 mm equivalence is by the diagonal (43.27 mm on full frame), so ``f_px = f_35 / 43.27 * diagonal_px``.
  The tag's whole value must be a plain ASCII number of millimetres in range (``26``, ``26.0``, ``26 mm``): a
  sign, an exponent, other digits (full-width) or other words make it unread, not a number found inside it.
- **Lens prior**: a phone's main camera (24-28 mm equivalent, the common case: one analyst with one phone)
  filming 16:9 video across the sensor's width, cropped 10-20 % by electronic stabilisation, sees about
  ``PRIOR_LONG_SIDE_FOV_DEG`` across the image's long side. Broadcast and lab lenses are narrower (30-50
  degrees); where the people measure the focal length (:mod:`platypose.lifting.calibration.from_people`) they override it.
"""

from __future__ import annotations

import math
import re

FULL_FRAME_DIAGONAL_MM = math.hypot(36.0, 24.0)
PRIOR_LONG_SIDE_FOV_DEG = 60.0
METADATA, PRIOR = "video metadata (35 mm equivalent)", "lens prior (a phone's main camera in video)"
LENS_RANGE_MM = (8.0, 800.0)  # 35 mm-equivalent focal lengths of real lenses, fisheye to long telephoto
_MILLIMETRES = re.compile(r"\s*([0-9]+(?:\.[0-9]+)?)\s*(?:mm)?\s*")


def prior_focal(size: tuple[int, int]) -> float:
    """The lens prior's focal length in pixels for an image ``size`` (height, width)."""
    return max(size) / 2.0 / math.tan(math.radians(PRIOR_LONG_SIDE_FOV_DEG) / 2.0)


def tag_millimetres(value: object) -> float | None:
    """A 35 mm-equivalent tag's value in millimetres when the whole value is a plain ASCII number (optionally
    followed by ``mm``) within ``LENS_RANGE_MM``; None otherwise (``-26``, ``26e3``, full-width digits, words)."""
    found = _MILLIMETRES.fullmatch(str(value))
    if found is None:
        return None
    millimetres = float(found.group(1))
    return millimetres if LENS_RANGE_MM[0] <= millimetres <= LENS_RANGE_MM[1] else None


def metadata_focal(tags: dict[str, str], size: tuple[int, int]) -> float | None:
    """The focal length in pixels from a video's metadata ``tags`` (container and stream together), or None when
    no tag names a plausible 35 mm-equivalent focal length (:func:`tag_millimetres`)."""
    for key, value in tags.items():
        if "35mm" not in key.lower().replace("_", "").replace(" ", ""):
            continue
        millimetres = tag_millimetres(value)
        if millimetres is not None:
            return millimetres / FULL_FRAME_DIAGONAL_MM * math.hypot(*size)
    return None


def lens_focal(tags: dict[str, str], size: tuple[int, int]) -> tuple[float, str]:
    """The focal length in pixels for ``size`` (height, width) and where it came from: the metadata, else the
    prior."""
    found = metadata_focal(tags, size)
    return (found, METADATA) if found is not None else (prior_focal(size), PRIOR)
