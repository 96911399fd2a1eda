"""holosoma-retargeting "mocap" joint positions: ``(T, 53, 3)`` float npy, metres, Z up, no frame rate stored."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from platypose.lifting.errors import InputError
from platypose.lifting.files.npz_limits import check_npy_size
from platypose.lifting.joint_maps import HOLOSOMA_MOCAP_NAMES, HOLOSOMA_MOCAP_RECIPE, apply_recipe
from platypose.lifting.motion import Motion

# The files store no rate; hand (~1.9 m/s) and foot (~3.2 m/s) peak speeds are
# plausible for climbing only at 120 frames per second.
DEFAULT_FPS = 120.0


def load_holosoma(path: Path, fps: float | None = None) -> list[Motion]:
    """One clip from a holosoma ``(T, 53, 3)`` npy file, at ``fps`` (default 120)."""
    try:
        check_npy_size(path)
        points = np.load(path, allow_pickle=False)
    except (OSError, ValueError) as err:
        raise InputError(f"{path}: not a readable .npy array ({err})") from None
    expected = (len(HOLOSOMA_MOCAP_NAMES), 3)
    if points.ndim != 3 or points.shape[1:] != expected or points.shape[0] == 0:
        raise InputError(f"{path}: expected holosoma joint positions (T, {expected[0]}, 3), got {points.shape}")
    if not np.isfinite(points).all():
        raise InputError(f"{path}: joint positions contain NaN or infinite values")
    joints = apply_recipe(points.astype(np.float64), HOLOSOMA_MOCAP_NAMES, HOLOSOMA_MOCAP_RECIPE)
    return [Motion(joints=joints, fps=fps or DEFAULT_FPS, name=path.stem, extra={"format": "holosoma"})]
