"""The native ``calib.json`` (docs/calibration.md): exact reader and atomic writer."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

from platypose.lifting.calibration.model import Calibration, new_meta
from platypose.lifting.calibration.validate import (
    as_array,
    as_distortion,
    as_rotation,
    as_size,
    check_camera_count,
    check_cameras,
    check_intrinsics,
    read_json,
)
from platypose.lifting.calibration.world import unit_scale, up_vector
from platypose.lifting.camera import Camera, written_distortion
from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import write_text_atomic

FORMAT = "platypose-calib"
VERSION = 1
REQUIRED_TOP = ("format", "version", "units", "world_up", "cameras")
REQUIRED_CAMERA = ("name", "size", "K", "t")
KNOWN_CAMERA = frozenset({"name", "size", "K", "dist", "R", "rvec", "t", "time_offset_s"})


def camera_from_dict(entry: Any, source: str, index: int) -> Camera:
    """One camera from its JSON object, every field checked."""
    where = f"camera {index}"
    if not isinstance(entry, dict):
        raise InputError(f"{source}: {where} is not a JSON object")
    missing = [k for k in REQUIRED_CAMERA if k not in entry]
    if "R" not in entry and "rvec" not in entry:
        missing.append("R (or rvec)")
    if missing:
        raise InputError(f"{source}: {where} is missing {', '.join(missing)}")
    unknown = sorted(set(entry) - KNOWN_CAMERA)
    if unknown:
        raise InputError(f"{source}: {where} has unknown fields {unknown}")
    if "R" in entry and "rvec" in entry:
        raise InputError(f"{source}: {where} gives both R and rvec; keep one")
    where = f"camera {entry['name']!r}"
    offset = as_array(entry.get("time_offset_s", 0.0), (1,), source, f"{where} time_offset_s")[0]
    return Camera(
        name=str(entry["name"]),
        size=as_size(entry["size"], source, f"{where} size"),
        K=check_intrinsics(entry["K"], source, f"{where} K"),
        dist=as_distortion(entry.get("dist", []), source, f"{where} dist"),
        R=as_rotation(entry["R"] if "R" in entry else entry["rvec"], source, f"{where} R/rvec"),
        t=as_array(entry["t"], (3,), source, f"{where} t"),
        time_offset_s=float(offset),
    )


def calibration_from_dict(data: Any, source: str) -> Calibration:
    """A calibration from the parsed native JSON, in the frame the file states (``meta`` world_up, units)."""
    if not isinstance(data, dict):
        raise InputError(f"{source}: top level is not a JSON object")
    missing = [k for k in REQUIRED_TOP if k not in data]
    if missing:
        raise InputError(f"{source}: missing field(s) {', '.join(missing)}")
    if data["format"] != FORMAT or data["version"] != VERSION:
        raise InputError(
            f"{source}: not a {FORMAT} version {VERSION} file (format {data['format']!r}, version {data['version']!r})"
        )
    unit_scale(data["units"], source)
    up_vector(data["world_up"], source)
    if not isinstance(data["cameras"], list):
        raise InputError(f"{source}: cameras must be a list")
    check_camera_count(len(data["cameras"]), source)
    cameras = check_cameras([camera_from_dict(c, source, i) for i, c in enumerate(data["cameras"])], source)
    stored = data.get("meta", {})
    if not isinstance(stored, dict):
        raise InputError(f"{source}: meta must be a JSON object")
    meta = {**new_meta(FORMAT, source, data["world_up"], data["units"]), **stored}
    return Calibration(cameras=cameras, meta={**meta, "world_up": data["world_up"], "units": data["units"]})


def camera_to_dict(camera: Camera) -> dict[str, Any]:
    """The JSON object of one camera (R as a matrix, so a round trip is exact)."""
    return {
        "name": camera.name,
        "size": list(camera.size),
        "K": camera.K.tolist(),
        "dist": written_distortion(camera.dist).tolist(),
        "R": camera.R.tolist(),
        "t": camera.t.tolist(),
        "time_offset_s": float(camera.time_offset_s),
    }


def calibration_to_dict(calibration: Calibration) -> dict[str, Any]:
    """The native JSON object of a Z-up metre calibration."""
    if calibration.meta.get("world_up", "z") != "z" or calibration.meta.get("units", "m") != "m":
        raise ValueError("only Z-up metre calibrations are written; convert with world.to_z_up_metres first")
    return {
        "format": FORMAT,
        "version": VERSION,
        "units": "m",
        "world_up": "z",
        "cameras": [camera_to_dict(c) for c in calibration.cameras],
        "meta": calibration.meta,
    }


def read_native(path: Path) -> Calibration:
    """Read a native ``calib.json``."""
    return calibration_from_dict(read_json(path), str(path))


def write_native(path: Path, calibration: Calibration) -> None:
    """Write a native ``calib.json`` atomically (temp file in the same folder, then rename)."""
    write_text_atomic(path, json.dumps(calibration_to_dict(calibration), indent=1, allow_nan=False) + "\n")
