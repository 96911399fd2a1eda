"""Training motion packed small into one file: every clip at the prior's rate, joints in whole millimetres.

``platypose train DATA... --pack FILE`` writes it; ``platypose train FILE`` trains from it as from DATA (the
same clips in the same order, so the same validation split). Each clip's joints are stored relative to its
first frame's pelvis as int16 millimetres (at most 0.5 mm from the resampled clip), the offsets, names,
sources, licences and original frame rates beside them, compressed: 34 minutes of motion take a few MB.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import atomic_open
from platypose.lifting.motion import Motion
from platypose.lifting.timebase import resample

PACK_KEY = "platypose_motion_pack"
PACK_VERSION = 1
LIMIT_MM = np.iinfo(np.int16).max


def is_pack(path: Path) -> bool:
    """Whether ``path`` is a motion pack written by :func:`write_pack`."""
    if path.suffix.lower() != ".npz" or not path.is_file():
        return False
    try:
        with np.load(path, allow_pickle=False) as data:
            return PACK_KEY in data.files
    except (OSError, ValueError):
        return False


def write_pack(motions: Sequence[Motion], path: str | Path, fps: float) -> int:
    """Write ``motions`` resampled to ``fps`` as one compressed pack (atomically); returns the frames written.

    Frames with a NaN joint are dropped, as training drops them; InputError for a clip that strays more than
    32.7 m from its first pelvis (int16 millimetres)."""
    parts, offsets, lengths = [], [], []
    for m in motions:
        joints = resample(m.joints[np.isfinite(m.joints).all(axis=(1, 2))], m.fps, fps)
        origin = joints[0, 0] if len(joints) else np.zeros(3)
        millimetres = np.round((joints - origin) * 1000.0)
        if len(joints) and np.abs(millimetres).max() > LIMIT_MM:
            raise InputError(f"{m.name}: strays more than {LIMIT_MM / 1000:g} m from its first frame; cannot pack")
        parts.append(millimetres.astype(np.int16))
        offsets.append(origin)
        lengths.append(len(joints))
    arrays = {
        PACK_KEY: np.array(PACK_VERSION),
        "fps": np.array(float(fps)),
        "joints_mm": np.concatenate(parts) if parts else np.zeros((0, 17, 3), np.int16),
        "origins": np.array(offsets, dtype=np.float64).reshape(-1, 3),
        "lengths": np.array(lengths, dtype=np.int64),
        "original_fps": np.array([m.extra.get("original_fps", m.fps) for m in motions], dtype=np.float64),
        "names": np.array([m.name for m in motions], dtype=str),
        "sources": np.array([m.source for m in motions], dtype=str),
        "licences": np.array([m.licence for m in motions], dtype=str),
    }
    with atomic_open(path, "wb") as stream:
        np.savez_compressed(stream, **arrays)
    return int(sum(lengths))


def read_pack(path: str | Path) -> list[Motion]:
    """The clips of a pack, each at the pack's rate with ``extra["original_fps"]``; InputError for a damaged one."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as data:
            version = int(data[PACK_KEY])
            fps = float(data["fps"])
            joints = data["joints_mm"].astype(np.float64) / 1000.0
            origins, lengths = data["origins"], data["lengths"]
            original, names = data["original_fps"], data["names"]
            sources, licences = data["sources"], data["licences"]
    except (OSError, ValueError, KeyError, TypeError) as err:
        raise InputError(f"{path}: not a readable motion pack ({type(err).__name__})") from None
    if version != PACK_VERSION:
        raise InputError(f"{path}: motion pack version {version} is not supported")
    count = len(lengths)
    if not (
        len(origins) == len(original) == len(names) == len(sources) == len(licences) == count
        and (lengths >= 0).all()
        and int(lengths.sum()) == len(joints)
        and joints.shape[1:] == (17, 3)
    ):
        raise InputError(f"{path}: motion pack is damaged (its clip table does not match its frames)")
    starts = np.concatenate([[0], np.cumsum(lengths)])
    return [
        Motion(
            joints[starts[i] : starts[i + 1]] + origins[i],
            fps,
            str(names[i]),
            str(sources[i]),
            str(licences[i]),
            extra={"original_fps": float(original[i])},
        )
        for i in range(count)
        if lengths[i] > 0
    ]
