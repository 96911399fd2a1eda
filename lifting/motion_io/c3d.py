"""C3D marker trials (clinical gait labs), read with ezc3d; joints from markers by C3D_MARKER_RECIPES.

Only joints the trial's markers define are filled; the others are NaN and
listed in ``Motion.extra["missing_joints"]``. Marker gaps (negative residual)
make the joints built from them NaN in those frames. The lab's up axis (Z or
Y) is found from the legs (hips above ankles) and turned to our Z up.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from platypose.lifting.errors import InputError
from platypose.lifting.joint_maps import C3D_MARKER_RECIPES
from platypose.lifting.motion import Motion
from platypose.lifting.motion_io.kinematics import LENGTH_UNITS, y_up_to_z_up
from platypose.lifting.skeleton import JOINT_INDEX, JOINT_NAMES, NUM_JOINTS


def header_frames(path: Path) -> int | None:
    """Frame count stated in the raw C3D header (None when the 16-bit header cannot state it)."""
    raw = path.read_bytes()[:512]
    if len(raw) < 10:
        raise InputError(f"{path}: too short for a C3D file")
    param_block = raw[0]
    with open(path, "rb") as f:
        f.seek(max(param_block - 1, 0) * 512 + 3)
        processor = f.read(1)
    order = "big" if processor == bytes([86]) else "little"  # 84 Intel, 85 DEC, 86 MIPS
    first, last = (int.from_bytes(raw[k : k + 2], order) for k in (6, 8))
    return None if last in (0, 0xFFFF) else last - first + 1


def read_markers(path: Path) -> tuple[list[str], np.ndarray, float, float]:
    """Marker labels (namespace stripped), positions ``(T, M, 3)`` with NaN in gaps, metres per unit, rate in Hz."""
    import ezc3d

    try:
        trial = ezc3d.c3d(str(path))
    except (RuntimeError, ValueError, OSError) as err:
        raise InputError(f"{path}: not a readable C3D file ({err})") from None
    point = trial["parameters"]["POINT"]
    stated = header_frames(path)
    if stated is not None and stated != trial["data"]["points"].shape[2]:
        held = trial["data"]["points"].shape[2]
        raise InputError(f"{path}: truncated C3D, header states {stated} frames, data holds {held}")
    labels = [label.rsplit(":", 1)[-1] for label in point["LABELS"]["value"]]
    positions = trial["data"]["points"][:3].transpose(2, 1, 0).astype(np.float64)
    residuals = trial["data"]["meta_points"]["residuals"][0].T
    positions[residuals < 0] = np.nan
    unit = point["UNITS"]["value"][0].strip().lower() if "UNITS" in point else "mm"
    if unit not in LENGTH_UNITS:
        raise InputError(f"{path}: unknown POINT:UNITS {unit!r}")
    return labels, positions, LENGTH_UNITS[unit], float(point["RATE"]["value"][0])


def markers_to_joints(labels: list[str], markers: np.ndarray) -> tuple[np.ndarray, dict[str, str]]:
    """Joints ``(T, 17, 3)`` (NaN where undefined) and, per defined joint, the points it was made from."""
    index = {label: i for i, label in enumerate(labels)}
    joints = np.full((markers.shape[0], NUM_JOINTS, 3), np.nan)
    used: dict[str, str] = {}
    for joint, alternatives in C3D_MARKER_RECIPES.items():
        for weights in alternatives:
            if all(name in index and np.isfinite(markers[:, index[name]]).any() for name in weights):
                joints[:, JOINT_INDEX[joint]] = sum(w * markers[:, index[name]] for name, w in weights.items())
                used[joint] = "+".join(weights)
                break
    return joints, used


def to_z_up(joints: np.ndarray) -> np.ndarray:
    """Rotate a Y-up trial to Z up; the up axis is where the hips sit above the ankles."""
    legs = [(JOINT_INDEX[f"{s}_hip"], JOINT_INDEX[f"{s}_ankle"]) for s in ("left", "right")]
    up = np.nanmean(np.concatenate([joints[:, h] - joints[:, a] for h, a in legs]), axis=0)
    if not np.isfinite(up).all():
        raise ValueError("no hip and ankle of one side to find the up axis")
    axis = int(np.argmax(np.abs(up)))
    if axis == 2 and up[2] > 0:
        return joints
    if axis == 1 and up[1] > 0:
        return y_up_to_z_up(joints)
    sign = "-" if up[axis] < 0 else "+"
    raise ValueError(f"legs point along {sign}{'xyz'[axis]}; only Z-up and Y-up labs are supported")


def load_c3d(path: Path, fps: float | None = None) -> list[Motion]:
    """One clip from a C3D trial: the joints its markers define, the rest NaN and listed as missing."""
    labels, markers, scale, rate = read_markers(path)
    joints, used = markers_to_joints(labels, markers * scale)
    if not used:
        raise InputError(f"{path}: no marker set we know (e.g. RHJC/RKJC/RAJC, Plug-in Gait RFEO/RTIO, epicondyles)")
    try:
        joints = to_z_up(joints)
    except ValueError as err:
        raise InputError(f"{path}: {err}") from None
    missing = [name for name in JOINT_NAMES if name not in used]
    extra = {"format": "c3d", "missing_joints": missing, "joint_sources": used}
    return [Motion(joints=joints, fps=fps or rate, name=path.stem, extra=extra)]
