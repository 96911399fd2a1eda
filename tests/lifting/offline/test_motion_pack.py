"""A motion pack is checked before it is trusted: its headers bounded, each array of its type, shape and range."""

from __future__ import annotations

import io
import zipfile
from pathlib import Path

import numpy as np
import pytest

from platypose.lifting.errors import InputError
from platypose.lifting.offline.motion_pack import PACK_FIELDS, is_pack, read_pack

PACK = Path(__file__).resolve().parents[3] / "data" / "motion-pack.npz"


@pytest.fixture(scope="module")
def arrays() -> dict[str, np.ndarray]:
    """The repository's pack, every array in memory."""
    with np.load(PACK, allow_pickle=False) as data:
        return {name: data[name] for name in PACK_FIELDS}


def written(path: Path, arrays: dict, **changes) -> Path:
    """A pack at ``path``: ``arrays`` with ``changes`` in place of some."""
    np.savez_compressed(path, **{**arrays, **changes})
    return path


def claiming(path: Path, arrays: dict, frames: int) -> Path:
    """A pack whose joints_mm header claims ``frames`` frames of int16 joints, with no values behind it."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<i2", "fortran_order": False, "shape": (frames, 17, 3)})
    with zipfile.ZipFile(path, "w") as archive:
        for name, value in arrays.items():
            member = io.BytesIO()
            np.lib.format.write_array(member, value)
            archive.writestr(f"{name}.npy", header.getvalue() if name == "joints_mm" else member.getvalue())
    return path


def test_the_repository_pack_reads(arrays):
    motions = read_pack(PACK)
    assert len(motions) == int((arrays["lengths"] > 0).sum()) and all(m.fps == float(arrays["fps"]) for m in motions)


def test_a_truncated_pack_is_known_as_one_and_refused(tmp_path):
    path = tmp_path / "trunc.npz"
    path.write_bytes(PACK.read_bytes()[:2267555])
    assert is_pack(path)
    with pytest.raises(InputError, match=r"trunc.npz: not a readable motion pack \(truncated or not a zip file\)$"):
        read_pack(path)


@pytest.mark.parametrize("fps", [0.0, float("nan"), -30.0, float("inf"), 1001.0])
def test_a_pack_fps_out_of_range_is_one_line(tmp_path, arrays, fps: float):
    path = written(tmp_path / "fps.npz", arrays, fps=np.array(fps))
    with pytest.raises(InputError, match=r"fps.npz: motion pack fps must be a number in \(0, 1000\], got "):
        read_pack(path)


@pytest.mark.parametrize("frames", [10**10, 3_000_000])
def test_a_header_claiming_too_many_frames_is_refused_unread(tmp_path, arrays, frames: int):
    path = claiming(tmp_path / "huge.npz", arrays, frames)
    with pytest.raises(InputError, match=r"huge.npz: not a readable motion pack \(array 'joints_mm' claims .* GiB"):
        read_pack(path)


def test_a_far_origin_is_one_line(tmp_path, arrays):
    origins = arrays["origins"].copy()
    origins[2, 1] = 1e300
    path = written(tmp_path / "far.npz", arrays, origins=origins)
    with pytest.raises(InputError, match=r"far.npz: motion pack origin of clip 2 is .*1e\+300.*, not within 1000 m$"):
        read_pack(path)


@pytest.mark.parametrize(
    "change, words",
    [
        ({"joints_mm": np.zeros((4, 17, 3))}, "joints_mm must be int16"),
        ({"lengths": np.array([2**62, 2**62, 2**62, 2**62])}, "clip lengths do not sum"),
        ({"original_fps": np.array([np.nan])}, "original_fps must be"),
        ({"names": np.arange(3)}, "names must be"),
        ({"platypose_motion_pack": np.array(7)}, "version 7 is not supported"),
    ],
    ids=["float-joints", "overflowing-lengths", "nan-original-fps", "numeric-names", "version"],
)
def test_a_pack_array_of_the_wrong_kind_is_one_line(tmp_path, arrays, change: dict, words: str):
    path = written(tmp_path / "bad.npz", arrays, **change)
    with pytest.raises(InputError, match=rf"bad.npz: motion pack .*{words}"):
        read_pack(path)
