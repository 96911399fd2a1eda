"""Human3.6M 3D poses as VideoPose3D's ``data_3d_h36m.npz``: ``positions_3d`` = {subject: {action: (T, 32, 3)}}.

Positions are world-frame metres with Z up (VideoPose3D divides the dataset's
millimetres by 1000 and keeps its world axes), at 50 fps. The 32 joints map
onto ours by H36M32_TO_OURS. Each subject/action is one clip named
``<file>/<subject>/<action>``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from platypose.lifting.errors import InputError
from platypose.lifting.joint_maps import H36M32_TO_OURS
from platypose.lifting.motion import Motion
from platypose.lifting.motion_io.plain_npz import npz_keys
from platypose.lifting.motion_io.safe_unpickle import load_object_member

H36M_FPS = 50.0
H36M_JOINTS = 32


def is_h36m_npz(path: Path) -> bool:
    """Whether an npz file holds a ``positions_3d`` array."""
    return "positions_3d" in npz_keys(path)


def load_h36m(path: Path, fps: float | None = None) -> list[Motion]:
    """One clip per subject and action, sorted by subject then action."""
    # positions_3d is a pickled dict of arrays, as VideoPose3D writes it; read without running the file's code.
    positions = load_object_member(path, "positions_3d")
    if not isinstance(positions, dict) or not all(isinstance(v, dict) for v in positions.values()):
        raise InputError(f"{path}: 'positions_3d' must be {{subject: {{action: (T, 32, 3)}}}}")
    clips = []
    for subject in sorted(positions):
        for action in sorted(positions[subject]):
            points = np.asarray(positions[subject][action], dtype=np.float64)
            if points.ndim != 3 or points.shape[1:] != (H36M_JOINTS, 3) or points.shape[0] == 0:
                raise InputError(f"{path}: {subject}/{action} must be (T, 32, 3), got {points.shape}")
            if not np.isfinite(points).all():
                raise InputError(f"{path}: {subject}/{action} contains NaN or infinite values")
            name = f"{path.stem}/{subject}/{action}"
            extra = {"format": "h36m", "subject": subject, "action": action}
            clips.append(Motion(joints=points[:, list(H36M32_TO_OURS)], fps=fps or H36M_FPS, name=name, extra=extra))
    if not clips:
        raise InputError(f"{path}: 'positions_3d' holds no clips")
    return clips
