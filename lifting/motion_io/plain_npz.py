"""Plain npz motion: ``joints`` (T, 17, 3) metres Z up on our skeleton, ``fps``, optional ``joint_names``."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np

from platypose.lifting.errors import InputError
from platypose.lifting.files.npz_limits import check_npz_sizes
from platypose.lifting.motion import Motion
from platypose.lifting.skeleton import JOINT_NAMES, NUM_JOINTS


def npz_keys(path: Path) -> set[str]:
    """Array names in an npz file (without reading the arrays); empty for a file that is not a zip."""
    try:
        with zipfile.ZipFile(path) as archive:
            return {name.removesuffix(".npy") for name in archive.namelist()}
    except (zipfile.BadZipFile, OSError):
        return set()


def is_plain_npz(path: Path) -> bool:
    """Whether an npz file holds a ``joints`` array."""
    return "joints" in npz_keys(path)


def load_plain_npz(path: Path, fps: float | None = None) -> list[Motion]:
    """One clip; joints are reordered to ours when ``joint_names`` lists our names in another order."""
    try:
        check_npz_sizes(path)
        with np.load(path, allow_pickle=False) as data:
            joints = np.asarray(data["joints"], dtype=np.float64)
            file_fps = float(data["fps"]) if "fps" in data else None
            names = [str(n) for n in data["joint_names"]] if "joint_names" in data else list(JOINT_NAMES)
    except (OSError, ValueError, TypeError, EOFError, zipfile.BadZipFile) as err:
        raise InputError(f"{path}: not a readable motion npz ({err})") from None
    if joints.ndim != 3 or joints.shape[1:] != (NUM_JOINTS, 3) or joints.shape[0] == 0:
        raise InputError(f"{path}: 'joints' must be (T, {NUM_JOINTS}, 3), got {joints.shape}")
    if sorted(names) != sorted(JOINT_NAMES):
        raise InputError(f"{path}: 'joint_names' must be our 17 joints ({', '.join(JOINT_NAMES)}), got {names}")
    if not np.isfinite(joints).all():
        raise InputError(f"{path}: 'joints' contains NaN or infinite values")
    rate = fps or file_fps
    if rate is None or not rate > 0:
        raise InputError(f"{path}: no positive 'fps' in the file; pass one")
    joints = joints[:, [names.index(n) for n in JOINT_NAMES]]
    return [Motion(joints=joints, fps=rate, name=path.stem, extra={"format": "plain_npz"})]
