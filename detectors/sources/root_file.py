"""A known pelvis path per person (``platypose lift --root-trajectory``), read from an npz or a CSV file.

npz: ``frame_times`` (T,) seconds and ``root`` (T, 3) or (P, T, 3) world metres.
CSV: a header ``time,x,y,z`` (one person) or ``person,time,x,y,z`` (person = 0..P-1).
"""

from __future__ import annotations

import csv
import zipfile
from pathlib import Path

import numpy as np

from platypose.lifting.errors import InputError
from platypose.lifting.files.npz_limits import check_npz_sizes
from platypose.lifting.timebase import interpolate


def _from_npz(path: Path) -> tuple[np.ndarray, np.ndarray]:
    try:
        check_npz_sizes(path)
        with np.load(path, allow_pickle=False) as data:
            times, root = np.asarray(data["frame_times"], float), np.asarray(data["root"], float)
    except KeyError as err:
        raise InputError(f"{path}: root trajectory npz needs 'frame_times' and 'root' (missing {err})") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile) as err:
        raise InputError(f"{path}: not a readable npz file ({err})") from None
    return times, root[None] if root.ndim == 2 else root


def _from_csv(path: Path) -> tuple[np.ndarray, np.ndarray]:
    try:
        with open(path, newline="", encoding="utf-8") as f:
            rows = list(csv.DictReader(f))
    except (OSError, UnicodeDecodeError) as err:
        raise InputError(f"{path}: cannot read the CSV ({err})") from None
    if not rows or not {"time", "x", "y", "z"} <= set(rows[0]):
        raise InputError(f"{path}: root trajectory CSV needs a header time,x,y,z (optionally person first)")
    try:
        persons = np.array([int(r.get("person") or 0) for r in rows])
        values = np.array([[float(r["time"]), float(r["x"]), float(r["y"]), float(r["z"])] for r in rows])
    except (TypeError, ValueError) as err:
        raise InputError(f"{path}: a value is not a number ({err})") from None
    times = np.unique(values[:, 0])
    root = np.full((persons.max() + 1, len(times), 3), np.nan)
    root[persons, np.searchsorted(times, values[:, 0])] = values[:, 1:]
    return times, root


def read_root_trajectory(path: Path, frame_times: np.ndarray, persons: int) -> np.ndarray:
    """Root paths ``(P, T, 3)`` from ``path`` on ``frame_times`` (T,); InputError if the file does not fit."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: root trajectory file not found")
    suffix = path.suffix.lower()
    if suffix not in (".npz", ".csv"):
        raise InputError(f"{path}: root trajectory must be .npz or .csv, got {suffix!r}")
    times, root = _from_npz(path) if suffix == ".npz" else _from_csv(path)
    if root.ndim != 3 or root.shape[-1] != 3 or root.shape[1] != len(times) or len(times) == 0:
        raise InputError(f"{path}: root must be (T, 3) or (P, T, 3) with T = len(frame_times), got {root.shape}")
    if not np.isfinite(root).all() or not (np.diff(times) > 0).all():
        raise InputError(f"{path}: root trajectory has missing values or times that do not increase")
    if root.shape[0] != persons:
        raise InputError(f"{path}: root trajectory has {root.shape[0]} person(s), {persons} are lifted (see --persons)")
    if frame_times[0] < times[0] - 0.5 or frame_times[-1] > times[-1] + 0.5:
        raise InputError(
            f"{path}: root trajectory covers {times[0]:.2f}-{times[-1]:.2f} s, the video "
            f"{frame_times[0]:.2f}-{frame_times[-1]:.2f} s"
        )
    return np.moveaxis(interpolate(np.moveaxis(root, 1, 0), times, frame_times), 0, 1)
