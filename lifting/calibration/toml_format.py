"""Pose2Sim / anipose / FreeMoCap calibration ``.toml``: one table per camera plus ``[metadata]``.

Per camera: ``name``, ``size`` [width, height], ``matrix`` 3x3, ``distortions`` [k1 k2 p1 p2 (k3)],
``rotation`` (Rodrigues, world -> camera), ``translation``, ``fisheye``. The file states neither
units nor up axis: we assume metres (Pose2Sim) and Z up (board on the floor), and say so in ``meta``.
"""

from __future__ import annotations

import sys
from pathlib import Path

from platypose.lifting.calibration import validate
from platypose.lifting.calibration.defaults import complete_camera
from platypose.lifting.calibration.model import Calibration, new_meta
from platypose.lifting.errors import InputError

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib

CAMERA_KEYS = frozenset({"name", "size", "matrix", "distortions", "rotation", "translation"})
ASSUMED_FRAME = "world frame not stated by the file: assumed Z up and metres (Pose2Sim convention)"


def read_toml(path: Path) -> Calibration:
    """Read every camera table of a Pose2Sim-style ``.toml``; tables with no camera key (``metadata``) are skipped."""
    source = str(path)
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError) as err:
        raise InputError(f"{source}: not valid TOML ({err})") from None
    meta = new_meta("pose2sim-toml", source, "z", "m")
    meta["assumptions"].append(ASSUMED_FRAME)
    cameras = []
    for key, table in data.items():
        if not isinstance(table, dict) or not CAMERA_KEYS & set(table):
            continue
        name = str(table.get("name", key))
        where = f"camera {name!r}"
        if table.get("fisheye", False):
            raise InputError(f"{source}: {where} uses the fisheye model, which platypose does not support")
        if "size" not in table:
            raise InputError(f"{source}: {where} is missing size")
        width, height = validate.as_size(table["size"], source, f"{where} size")
        K = validate.check_intrinsics(table["matrix"], source, f"{where} matrix") if "matrix" in table else None
        dist = validate.as_distortion(table.get("distortions", []), source, f"{where} distortions")
        has_extrinsics = "rotation" in table and "translation" in table
        if ("rotation" in table) != ("translation" in table):
            raise InputError(f"{source}: {where} has only one of rotation and translation")
        R = validate.as_rotation(table["rotation"], source, f"{where} rotation") if has_extrinsics else None
        t = validate.as_array(table["translation"], (3,), source, f"{where} translation") if has_extrinsics else None
        camera, notes = complete_camera(name, (height, width), K, dist, R, t)
        cameras.append(camera)
        meta["assumptions"].extend(notes)
    return Calibration(cameras=validate.check_cameras(cameras, source), meta=meta)
