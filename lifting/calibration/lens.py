"""The focal length of an uncalibrated video where its people cannot measure it: the lens its metadata names, else a
prior over common lenses.

- **Metadata**: phones often write the lens as a 35 mm-equivalent focal length (a tag whose name holds ``35mm``).
  35 mm equivalence is by the diagonal (43.27 mm on full frame), so ``f_px = f_35 / 43.27 * diagonal_px``.
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


def prior_focal(size: tuple[int, int]) -> float:
    """The lens prior's focal length in pixels for an image ``size`` (height, width)."""
    return max(size) / 2.0 / math.tan(math.radians(PRIOR_LONG_SIDE_FOV_DEG) / 2.0)


def metadata_focal(tags: dict[str, str], size: tuple[int, int]) -> float | None:
    """The focal length in pixels from a video's metadata ``tags`` (container and stream together), or None when
    no tag names a plausible 35 mm-equivalent focal length (8-800 mm)."""
    for key, value in tags.items():
        if "35mm" not in key.lower().replace("_", "").replace(" ", ""):
            continue
        found = re.search(r"\d+(\.\d+)?", str(value))
        if found and 8.0 <= float(found.group()) <= 800.0:
            return float(found.group()) / FULL_FRAME_DIAGONAL_MM * math.hypot(*size)
    return None


def lens_focal(tags: dict[str, str], size: tuple[int, int]) -> tuple[float, str]:
    """The focal length in pixels for ``size`` (height, width) and where it came from: the metadata, else the
    prior."""
    found = metadata_focal(tags, size)
    return (found, METADATA) if found is not None else (prior_focal(size), PRIOR)
