"""Calibration ``.toml`` of Pose2Sim, anipose, FreeMoCap and Caliscope: one table per camera; :func:`write_toml`
writes the Pose2Sim layout.

Pose2Sim / anipose / FreeMoCap: ``[cam_N]`` (or any name) tables with ``name``, ``size`` [width,
height], ``matrix`` 3x3, ``distortions`` [k1 k2 p1 p2 (k3 (k4 k5 k6))], ``rotation`` (Rodrigues, world ->
camera), ``translation``, ``fisheye``, plus ``[metadata]``; FreeMoCap's metadata names a charuco
board. Caliscope ``camera_array.toml`` / ``config.toml``: ``[cameras.N]`` tables with ``cam_id``,
``size``, ``matrix``, ``distortions``, ``rotation`` (3x3 or Rodrigues, world -> camera),
``translation``, ``ignore``; workspace keys (``rotation_count``, ``exposure``, ``grid_count``,
``error``) are not calibration and are ignored.

None of these files states its units or up axis. Pose2Sim works in metres with Z up; anipose,
FreeMoCap and Caliscope put the world in one camera's frame, FreeMoCap often in millimetres. So
both are detected from the cameras (``plausible``) and stated in ``meta``; ``--units`` and
``--world-up`` override.
"""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import cv2
import numpy as np

from platypose.lifting.calibration.defaults import complete_camera
from platypose.lifting.calibration.model import Calibration, new_meta
from platypose.lifting.calibration.plausible import detect_units, detect_up
from platypose.lifting.calibration.validate import (
    as_array,
    as_distortion,
    as_rotation,
    as_size,
    check_camera_count,
    check_cameras,
    check_intrinsics,
    read_calibration_bytes,
)
from platypose.lifting.camera import Camera, written_distortion
from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import write_text_atomic

if sys.version_info >= (3, 11):
    import tomllib
else:
    import tomli as tomllib

CAMERA_KEYS = frozenset({"name", "size", "matrix", "distortions", "rotation", "translation"})
FREEMOCAP_METADATA = frozenset({"charuco_square_size", "charuco_board_object"})


def _table_camera(table: dict[str, Any], name: str, source: str) -> tuple[Camera, list[str]]:
    """One camera from a Pose2Sim/anipose/Caliscope table, with the notes of any defaults used."""
    where = f"camera {name!r}"
    if table.get("fisheye", False):
        raise InputError(f"{source}: {where} uses the fisheye model, which platypose does not support")
    if "size" not in table:
        raise InputError(f"{source}: {where} is missing size")
    width, height = as_size(table["size"], source, f"{where} size")
    K = check_intrinsics(table["matrix"], source, f"{where} matrix") if "matrix" in table else None
    dist = as_distortion(table.get("distortions", []), source, f"{where} distortions")
    if ("rotation" in table) != ("translation" in table):
        raise InputError(f"{source}: {where} has only one of rotation and translation")
    has_extrinsics = "rotation" in table
    R = as_rotation(table["rotation"], source, f"{where} rotation") if has_extrinsics else None
    t = as_array(table["translation"], (3,), source, f"{where} translation") if has_extrinsics else None
    return complete_camera(name, (height, width), K, dist, R, t)


def _caliscope_tables(data: dict[str, Any], source: str) -> list[tuple[str, dict[str, Any]]]:
    """(name, table) per Caliscope camera, named ``cam_<id>``; ``ignore = true`` cameras are left out."""
    cameras = data["cameras"]
    if not isinstance(cameras, dict) or not all(isinstance(t, dict) for t in cameras.values()):
        raise InputError(f"{source}: [cameras] must hold one table per camera")
    return [(f"cam_{table.get('cam_id', key)}", table) for key, table in cameras.items() if not table.get("ignore")]


def _layout(data: dict[str, Any]) -> str:
    """Which tool wrote the file: ``caliscope``, ``freemocap`` or ``pose2sim`` (also anipose)."""
    if isinstance(data.get("cameras"), dict):
        return "caliscope"
    metadata = data.get("metadata")
    if isinstance(metadata, dict) and FREEMOCAP_METADATA & set(metadata):
        return "freemocap"
    return "pose2sim"


def read_toml(path: Path) -> Calibration:
    """Read every camera of a calibration ``.toml``, detecting units and up axis from the cameras."""
    source = str(path)
    try:
        data = tomllib.loads(read_calibration_bytes(path).decode("utf-8"))
    except (UnicodeDecodeError, tomllib.TOMLDecodeError, RecursionError) as err:
        raise InputError(f"{source}: not valid TOML ({err})") from None
    layout = _layout(data)
    if layout == "caliscope":
        tables = _caliscope_tables(data, source)
    else:
        tables = [
            (str(t.get("name", key)), t) for key, t in data.items() if isinstance(t, dict) and CAMERA_KEYS & set(t)
        ]
    check_camera_count(len(tables), source)
    cameras, notes = [], []
    for name, table in tables:
        camera, camera_notes = _table_camera(table, name, source)
        cameras.append(camera)
        notes.extend(camera_notes)
    cameras = check_cameras(cameras, source)
    units, units_note = detect_units(cameras)
    up, up_note = detect_up(cameras)
    meta = new_meta(f"{layout}-toml", source, up, units)
    meta["assumptions"] = [n for n in (units_note, up_note) if n] + notes
    if not units_note and not up_note:
        meta["assumptions"].insert(
            0, "world frame not stated by the file: assumed Z up and metres (they fit the cameras)"
        )
    return Calibration(cameras=cameras, meta=meta)


def write_toml(path: Path, cameras: list[Camera], comments: list[str] = ()) -> None:
    """Write ``cameras`` (z up, metres) as a Pose2Sim ``.toml`` atomically, ``comments`` as ``#`` lines on top."""
    lines = [f"# {line}" for text in comments for line in text.splitlines()]
    for camera in cameras:
        rotation = cv2.Rodrigues(np.asarray(camera.R, np.float64))[0].ravel()
        lines += [
            "",
            f"[{_key(camera.name)}]",
            f"name = {_string(camera.name)}",
            f"size = [ {camera.width:.1f}, {camera.height:.1f}]",
            "matrix = [ " + ", ".join(_numbers(row) for row in np.asarray(camera.K, np.float64)) + "]",
            f"distortions = {_numbers(written_distortion(camera.dist))}",
            f"rotation = {_numbers(rotation)}",
            f"translation = {_numbers(np.asarray(camera.t, np.float64))}",
            "fisheye = false",
        ]
    write_text_atomic(path, "\n".join(lines).lstrip("\n") + "\n")


def _numbers(values: np.ndarray) -> str:
    return "[ " + ", ".join(repr(float(v)) for v in values) + "]"


def _string(text: str) -> str:
    return '"' + text.replace("\\", "\\\\").replace('"', '\\"') + '"'


def _key(text: str) -> str:
    return text if text.replace("_", "").replace("-", "").isalnum() and text.isascii() else _string(text)
