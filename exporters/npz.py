"""The npz file, the source of truth: writer and validating reader."""

from __future__ import annotations

import json
import zipfile
from pathlib import Path
from typing import IO

import numpy as np

from platypose.exporters.angles import ANGLE_NAMES, SERIES_COLUMNS, angle_series
from platypose.exporters.frames import FrameArray, frame_chunks
from platypose.exporters.npz_checks import check_coordinates, check_field_sizes
from platypose.exporters.result import LiftResult
from platypose.lifting.calibration.model import Calibration, new_meta
from platypose.lifting.calibration.native import FORMAT, calibration_from_dict, calibration_to_dict
from platypose.lifting.camera import Camera
from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import atomic_open
from platypose.lifting.skeleton import JOINT_NAMES, PARENTS

REQUIRED = (
    "hypotheses",
    "median",
    "keypoints2d",
    "frame_times",
    "fps",
    "joint_names",
    "parents",
    "track_ids",
    "cameras",
    "units",
    "up_axis",
    "meta",
)


# Written a chunk of frames at a time.
FRAME_AXES = {"hypotheses": 2, "median": 1, "keypoints2d": 2, "energy": 2, "angles": 1}


def cameras_json(cameras: tuple[Camera, ...]) -> str:
    """The cameras as native calibration JSON text (``platypose-calib`` version 1)."""
    calibration = Calibration(cameras=cameras, meta=new_meta(FORMAT, "platypose result", "z", "m"))
    return json.dumps(calibration_to_dict(calibration))


def angle_array(result: LiftResult, series: dict[int, np.ndarray]) -> np.ndarray:
    """The npz's ``angles`` ``(P, T, A, 4)`` float32 from :func:`exporters.angles.angle_series` (NaN for a person
    without a series)."""
    out = np.full((result.num_persons, result.num_frames, len(ANGLE_NAMES), len(SERIES_COLUMNS)), np.nan, np.float32)
    for p, values in series.items():
        out[p] = values
    return out


def result_arrays(result: LiftResult, series: dict[int, np.ndarray]) -> dict[str, np.ndarray | FrameArray]:
    """The npz fields of ``result`` as plain arrays (no pickled objects; long ones may stay on disk), its joint
    angles from ``series`` (:func:`exporters.angles.angle_series`)."""
    arrays = {
        "hypotheses": result.hypotheses,
        "median": result.median,
        "keypoints2d": result.keypoints2d,
        "frame_times": result.frame_times,
        "fps": np.float64(result.fps),
        "joint_names": np.array(JOINT_NAMES),
        "parents": np.array(PARENTS, dtype=np.int64),
        "track_ids": result.track_ids,
        "cameras": np.array(cameras_json(result.cameras)),
        "units": np.array(result.units),
        "up_axis": np.array(result.up_axis),
        "meta": np.array(json.dumps(result.meta, sort_keys=True)),
        "angles": angle_array(result, series),
        "angle_names": np.array(ANGLE_NAMES),
        "angle_columns": np.array(SERIES_COLUMNS),
    }
    if result.energy is not None:
        arrays["energy"] = result.energy
    return arrays


def write_npz(result: LiftResult, path: Path | str, series: dict[int, np.ndarray] | None = None) -> Path:
    """Write ``result`` to ``path`` (npz, as ``np.savez`` would) atomically; meta must be JSON-serialisable.

    Its joint angles are ``series`` (:func:`exporters.angles.angle_series` of ``result``; None: computed here).
    Long arrays are copied a chunk of frames at a time.
    """
    path = Path(path)
    try:
        arrays = result_arrays(result, angle_series(result) if series is None else series)
    except TypeError as err:
        raise InputError(f"{path}: meta is not JSON-serialisable ({err})") from None
    with atomic_open(path) as f, zipfile.ZipFile(f, mode="w", compression=zipfile.ZIP_STORED, allowZip64=True) as z:
        for key, value in arrays.items():
            with z.open(f"{key}.npy", "w", force_zip64=True) as member:  # as np.savez writes them
                _write_npy(member, value, FRAME_AXES.get(key))
    return path


def _write_npy(stream: IO[bytes], values: np.ndarray | FrameArray, frame_axis: int | None) -> None:
    """``np.save`` of ``values`` into ``stream``; with a ``frame_axis``, copied a chunk of frames at a time."""
    if frame_axis is None:
        np.lib.format.write_array(stream, values, allow_pickle=False)
        return
    header = {"descr": np.lib.format.dtype_to_descr(values.dtype), "fortran_order": False, "shape": values.shape}
    np.lib.format.write_array_header_1_0(stream, header)
    for lead in np.ndindex(*values.shape[:frame_axis]):
        for t in frame_chunks(values.shape[frame_axis]):
            stream.write(np.ascontiguousarray(values[lead + (t,)]).tobytes())


def _text(data: np.lib.npyio.NpzFile, key: str) -> str:
    """A 0-d string field."""
    value = data[key]
    if value.dtype.kind != "U" or value.ndim != 0:
        raise ValueError(f"field {key!r} must be a string")
    return str(value)


def _json(data: np.lib.npyio.NpzFile, key: str) -> object:
    """A 0-d string field read as JSON; ValueError saying what is wrong (a number of thousands of digits, which
    Python's reader refuses in words of its own, included)."""
    try:
        return json.loads(_text(data, key))
    except ValueError as err:
        if "integer string conversion" in str(err):
            raise ValueError(f"field {key!r} holds an integer of thousands of digits") from None
        raise


def read_npz(path: Path | str) -> LiftResult:
    """Read and validate a platypose npz; any problem raises InputError naming the file."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    try:
        check_field_sizes(path)
        with np.load(path, allow_pickle=False) as data:
            missing = [k for k in REQUIRED if k not in data.files]
            if missing:
                raise ValueError(f"not a platypose result, missing fields {', '.join(missing)}")
            if [str(n) for n in data["joint_names"]] != list(JOINT_NAMES):
                raise ValueError("joint_names differ from platypose's 17-joint skeleton")
            if data["parents"].tolist() != list(PARENTS):
                raise ValueError("parents differ from platypose's skeleton")
            if _text(data, "units") != "m" or _text(data, "up_axis") != "z":
                raise ValueError("units must be 'm' and up_axis 'z'")
            meta = _json(data, "meta")
            if not isinstance(meta, dict):
                raise ValueError("meta must be a JSON object")
            fields = {key: data[key] for key in ("hypotheses", "median", "keypoints2d", "frame_times", "track_ids")}
            for key, value in fields.items():
                if value.dtype.kind not in "fiu":
                    raise ValueError(f"field {key!r} must be numeric, got {value.dtype}")
            check_coordinates("hypotheses", fields["hypotheses"])
            check_coordinates("median", fields["median"])
            return LiftResult(
                hypotheses=fields["hypotheses"],
                median=fields["median"],
                keypoints2d=fields["keypoints2d"],
                frame_times=fields["frame_times"],
                fps=float(data["fps"]),
                track_ids=fields["track_ids"],
                cameras=calibration_from_dict(_json(data, "cameras"), f"{path} cameras").cameras,
                energy=data["energy"] if "energy" in data.files else None,
                meta=meta,
            )
    except InputError:
        raise
    except EOFError:
        raise InputError(f"{path}: empty or truncated npz file") from None
    except (ValueError, KeyError, OSError, zipfile.BadZipFile, json.JSONDecodeError) as err:
        raise InputError(f"{path}: {err}") from None
    except RecursionError:
        raise InputError(f"{path}: meta or cameras nested too deeply") from None
