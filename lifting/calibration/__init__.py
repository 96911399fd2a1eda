"""Camera calibration: read every supported format, check it, express it Z-up in metres, write the native JSON.

``load_calibration`` dispatches on the path: a folder or ``intri.yml``/``extri.yml`` (EasyMocap),
``.toml`` (Pose2Sim / anipose / FreeMoCap / Caliscope, told apart by content), ``.yml``/``.yaml``/``.xml``
(OpenCV FileStorage), ``.json`` (native ``platypose-calib`` or Human3.6M cameras, told apart by content),
``.qca.txt`` (Qualisys), ``.xcp`` (Vicon) and other ``.txt`` (intrinsics only).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from platypose.lifting.calibration.h36m import is_h36m, read_h36m
from platypose.lifting.calibration.intrinsics_only import read_intrinsics
from platypose.lifting.calibration.model import Calibration
from platypose.lifting.calibration.native import read_native, write_native
from platypose.lifting.calibration.opencv_yml import is_easymocap, read_opencv_yml
from platypose.lifting.calibration.qualisys import is_qualisys, read_qualisys
from platypose.lifting.calibration.toml_format import read_toml
from platypose.lifting.calibration.validate import read_calibration_bytes, read_json
from platypose.lifting.calibration.vicon import is_vicon, read_vicon
from platypose.lifting.calibration.world import to_z_up_metres
from platypose.lifting.errors import InputError

__all__ = ["Calibration", "load_calibration", "save_calibration"]

# Cameras farther than this from the world origin (after unit conversion) mean the units are wrong.
MAX_CAMERA_DISTANCE_M = 100.0
# Cameras of one rig stand farther apart than this (a file in metres read as mm puts them millimetres apart).
MIN_RIG_SPREAD_M = 0.02
MIN_CAMERA_GAP_M = 1e-4  # two cameras closer than this are one place given twice
WITHOUT_EXTRINSICS = ("intrinsics-txt", "default")


def _read_json(path: Path, subject: str | None) -> Calibration:
    """Native or Human3.6M JSON, by content."""
    data = read_json(path)
    if isinstance(data, dict) and "format" in data:
        return read_native(path)
    if is_h36m(data):
        return read_h36m(path, subject)
    raise InputError(f"{path}: JSON is neither a platypose-calib file nor Human3.6M camera parameters")


def _read_any(path: Path, subject: str | None) -> Calibration:
    """Read ``path`` in its own world frame, choosing the reader from the path."""
    suffix = path.suffix.lower()
    if is_easymocap(path) or suffix in (".yml", ".yaml", ".xml"):
        return read_opencv_yml(path)
    if suffix == ".toml":
        return read_toml(path)
    if suffix == ".json":
        return _read_json(path, subject)
    if is_qualisys(path):
        return read_qualisys(path)
    if is_vicon(path):
        return read_vicon(path)
    if suffix == ".txt":
        return read_intrinsics(path)
    raise InputError(
        f"{path}: unknown calibration format (expected .json, .toml, .yml, .qca.txt, .xcp, .txt or an EasyMocap folder)"
    )


def _check_distances(path: Path, calibration: Calibration, units_read: str | float) -> None:
    """Refuse cameras implausibly far from the origin: the units are almost surely wrong."""
    distances = [float(np.linalg.norm(c.center)) for c in calibration.cameras]
    if max(distances) > MAX_CAMERA_DISTANCE_M:
        raise InputError(
            f"{path}: a camera is {max(distances):.0f} m from the origin; the units look wrong "
            f"(file read as {units_read}); pass units mm, cm or m",
            option="units",
        )


def _check_spacing(path: Path, calibration: Calibration, units_read: str | float) -> None:
    """Refuse two cameras at one place, and a rig whose cameras all lie within ``MIN_RIG_SPREAD_M`` (a file in
    metres read as millimetres). Files without extrinsics (intrinsics only, defaults) are not checked."""
    if calibration.meta.get("format") in WITHOUT_EXTRINSICS or len(calibration.cameras) < 2:
        return
    centres = np.stack([c.center for c in calibration.cameras])
    gaps = np.linalg.norm(centres[:, None] - centres[None], axis=-1)  # at most MAX_CAMERAS squared
    if gaps.max() < MIN_RIG_SPREAD_M:
        raise InputError(
            f"{path}: the cameras all lie within {gaps.max() * 1000:.1f} mm of one another; the units look wrong "
            f"(file read as {units_read}) or the positions are missing; pass units mm, cm or m",
            option="units",
        )
    np.fill_diagonal(gaps, np.inf)
    i, j = np.unravel_index(np.argmin(gaps), gaps.shape)
    if gaps[i, j] < MIN_CAMERA_GAP_M:
        names = calibration.names
        raise InputError(
            f"{path}: cameras {names[i]} and {names[j]} are at the same place ({gaps[i, j] * 1000:.2f} mm apart)"
        )


def load_calibration(
    path: str | Path, world_up: str | None = None, units: str | float | None = None, subject: str | None = None
) -> Calibration:
    """Read any supported calibration and return it Z-up in metres; ``world_up``/``units`` override the file.

    ``subject`` picks the extrinsics of a Human3.6M file that holds several subjects.
    """
    path = Path(path)
    if not path.exists():
        raise InputError(f"{path}: calibration file not found")
    if not path.is_dir():
        read_calibration_bytes(path)  # a regular file within the size limit (readers by path, such as OpenCV's, too)
    raw = _read_any(path, subject)
    result = to_z_up_metres(raw, world_up, units)
    _check_distances(path, result, units if units is not None else raw.meta["units"])
    _check_spacing(path, result, units if units is not None else raw.meta["units"])
    return result


def save_calibration(path: str | Path, calibration: Calibration) -> None:
    """Write the native ``calib.json`` atomically."""
    write_native(Path(path), calibration)
