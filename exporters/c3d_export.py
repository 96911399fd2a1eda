"""C3D marker files (ezc3d): one per person, millimetres, the TRC's Y-up axes with Visual3D screen axes."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from platypose.exporters.markers import MARKER_NAMES, to_opensim_axes
from platypose.lifting.files.atomic import atomic_path

MM_PER_M = 1000.0


def write_c3d(joints: np.ndarray, present: np.ndarray, fps: float, path: Path | str) -> Path:
    """Write filled world joints (T, 17, 3) metres (no NaN) as a C3D file at ``path`` atomically.

    Points are the TRC's axes in millimetres; ``POINT:X_SCREEN`` / ``Y_SCREEN`` are ``+Z`` / ``+Y``
    (Y up in viewers, as Pose2Sim writes). Each point's residual is 0 on filled frames
    (``present`` (T,) False: C3D's "interpolated") and 1 on measured ones.
    """
    import ezc3d

    path = Path(path)
    if not np.isfinite(joints).all():
        raise ValueError(f"{path}: C3D needs filled joints (no NaN)")
    T = len(joints)
    c3d = ezc3d.c3d()
    c3d["parameters"]["POINT"]["RATE"]["value"] = [float(fps)]
    c3d["parameters"]["POINT"]["LABELS"]["value"] = list(MARKER_NAMES)
    c3d["parameters"]["POINT"]["UNITS"]["value"] = ["mm"]
    c3d.add_parameter("POINT", "X_SCREEN", ["+Z"])
    c3d.add_parameter("POINT", "Y_SCREEN", ["+Y"])
    points = np.ones((4, len(MARKER_NAMES), T))
    points[:3] = np.moveaxis(to_opensim_axes(joints) * MM_PER_M, -1, 0).transpose(0, 2, 1)
    c3d["data"]["points"] = points
    residuals = np.broadcast_to(np.where(present, 1.0, 0.0)[None, None], (1, len(MARKER_NAMES), T))
    c3d["data"]["meta_points"]["residuals"] = np.ascontiguousarray(residuals)
    with atomic_path(path, streams=False) as tmp:  # ezc3d's own file is renamed onto tmp: never a device
        named = tmp.with_name(tmp.name + ".c3d")  # ezc3d appends .c3d to a name that lacks it
        try:
            c3d.write(str(named))
            os.replace(named, tmp)
        finally:
            named.unlink(missing_ok=True)
    return path
