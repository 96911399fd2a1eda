"""Training motion packed small into one file: every clip at the prior's rate, joints in whole millimetres.

``platypose train DATA... --pack FILE`` writes it; ``platypose train FILE`` trains from it as from DATA (the
same clips in the same order, so the same validation split). Each clip's joints are stored relative to its
first frame's pelvis as int16 millimetres (at most 0.5 mm from the resampled clip), the offsets, names,
sources, licences and original frame rates beside them, compressed: 34 minutes of motion take a few MB.

Reading one checks it before it is trusted: the arrays' headers within ``MAX_PACK_ARRAY_BYTES`` before any is
loaded (a crafted header or deflated zeros cannot ask for gigabytes), each array of its type and shape, the frame
rates finite within (0, ``MAX_FPS``], the origins within ``MAX_DISTANCE_M`` and every clip through the checks of
any loaded motion; else one line naming the pack and the problem.
"""

from __future__ import annotations

import zipfile
from collections.abc import Sequence
from pathlib import Path

import numpy as np

from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import atomic_open
from platypose.lifting.files.npz_limits import check_npz_sizes
from platypose.lifting.motion import Motion
from platypose.lifting.motion_io.checks import MAX_DISTANCE_M, check_motion
from platypose.lifting.motion_io.plain_npz import npz_keys
from platypose.lifting.skeleton import NUM_JOINTS
from platypose.lifting.timebase import resample

PACK_KEY = "platypose_motion_pack"
PACK_VERSION = 1
LIMIT_MM = np.iinfo(np.int16).max
MAX_PACK_ARRAY_BYTES = 2**28  # joints_mm of 2.6 M frames (12 h at 60 fps); the repository's pack holds 34 min
MAX_FPS = 1000.0
PACK_FIELDS = (PACK_KEY, "fps", "joints_mm", "origins", "lengths", "original_fps", "names", "sources", "licences")


def is_pack(path: Path) -> bool:
    """Whether ``path`` is a motion pack written by :func:`write_pack`: an npz whose first member (its local
    header, at the start of the file, so a truncated pack is still known as one) or one of whose members is the
    pack's marker."""
    if path.suffix.lower() != ".npz" or not path.is_file():
        return False
    marker = f"{PACK_KEY}.npy".encode()
    try:
        with open(path, "rb") as stream:
            head = stream.read(30 + len(marker))
    except OSError:
        return False
    return (head[:4] == b"PK\x03\x04" and head[30:] == marker) or PACK_KEY in npz_keys(path)


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


def _load_arrays(path: Path) -> dict[str, np.ndarray]:
    """The pack's arrays, their headers checked first; InputError naming the pack when it is not a readable npz
    (truncated, damaged, an array missing or claiming too much)."""
    try:
        check_npz_sizes(path, MAX_PACK_ARRAY_BYTES, 2 * MAX_PACK_ARRAY_BYTES)
        with np.load(path, allow_pickle=False) as data:
            return {name: np.asarray(data[name]) for name in PACK_FIELDS}
    except KeyError as err:
        raise InputError(f"{path}: not a readable motion pack (no array {err})") from None
    except zipfile.BadZipFile:
        raise InputError(f"{path}: not a readable motion pack (truncated or not a zip file)") from None
    except (OSError, ValueError, TypeError, EOFError, zipfile.LargeZipFile) as err:
        raise InputError(f"{path}: not a readable motion pack ({err})".replace("\n", " ")) from None


def _rates_ok(values: np.ndarray) -> bool:
    return values.dtype.kind in "fiu" and bool(np.all(np.isfinite(values) & (values > 0) & (values <= MAX_FPS)))


def check_pack(path: Path, arrays: dict[str, np.ndarray]) -> None:
    """InputError naming the pack ``path`` and the first array whose type, shape or values are not those
    :func:`write_pack` writes: a whole version, ``fps`` finite in (0, ``MAX_FPS``], ``joints_mm`` int16 frames of
    our joints, per clip a length (summing to the frames), an origin within ``MAX_DISTANCE_M`` m, an original rate
    like ``fps``, a name, a source and a licence."""
    version, fps, joints = arrays[PACK_KEY], arrays["fps"], arrays["joints_mm"]
    if version.shape != () or version.dtype.kind not in "iu" or int(version) != PACK_VERSION:
        raise InputError(f"{path}: motion pack version {repr(version.tolist())[:40]} is not supported")
    if fps.shape != () or not _rates_ok(fps):
        raise InputError(f"{path}: motion pack fps must be a number in (0, {MAX_FPS:g}], got {repr(fps.tolist())[:40]}")
    if joints.dtype != np.int16 or joints.ndim != 3 or joints.shape[1:] != (NUM_JOINTS, 3):
        raise InputError(
            f"{path}: motion pack joints_mm must be int16 (frames, {NUM_JOINTS}, 3), got {joints.dtype} {joints.shape}"
        )
    lengths, origins = arrays["lengths"], arrays["origins"]
    count = len(lengths) if lengths.ndim == 1 else -1
    whole = count >= 0 and lengths.dtype.kind in "iu" and ((lengths >= 0) & (lengths <= len(joints))).all()
    if not whole or int(lengths.sum()) != len(joints):
        raise InputError(f"{path}: motion pack is damaged (its clip lengths do not sum to its {len(joints)} frames)")
    if origins.shape != (count, 3) or origins.dtype.kind not in "fiu":
        raise InputError(f"{path}: motion pack origins must be ({count}, 3) numbers, got {origins.shape}")
    with np.errstate(invalid="ignore"):
        far = ~(np.abs(origins) <= MAX_DISTANCE_M)  # NaN too
    if far.any():
        clip = int(np.nonzero(far.any(axis=1))[0][0])
        raise InputError(
            f"{path}: motion pack origin of clip {clip} is {origins[clip].tolist()}, not within {MAX_DISTANCE_M:g} m"
        )
    if arrays["original_fps"].shape != (count,) or not _rates_ok(arrays["original_fps"]):
        raise InputError(f"{path}: motion pack original_fps must be {count} numbers in (0, {MAX_FPS:g}]")
    for name in ("names", "sources", "licences"):
        if arrays[name].shape != (count,) or arrays[name].dtype.kind != "U":
            raise InputError(f"{path}: motion pack {name} must be {count} texts, got {arrays[name].shape}")


def read_pack(path: str | Path) -> list[Motion]:
    """The clips of a pack (:func:`check_pack`), each at the pack's rate with ``extra["original_fps"]`` and
    checked as any loaded motion is; InputError naming the pack for a damaged one."""
    path = Path(path)
    arrays = _load_arrays(path)
    check_pack(path, arrays)
    fps, lengths = float(arrays["fps"]), arrays["lengths"]
    starts = np.concatenate([[0], np.cumsum(lengths)])
    motions = []
    for i in np.nonzero(lengths > 0)[0]:
        joints = arrays["joints_mm"][starts[i] : starts[i + 1]] / 1000.0 + arrays["origins"][i]
        extra = {"original_fps": float(arrays["original_fps"][i])}
        motion = Motion(
            joints, fps, str(arrays["names"][i]), str(arrays["sources"][i]), str(arrays["licences"][i]), extra=extra
        )
        check_motion(motion, str(path))
        motions.append(motion)
    return motions
