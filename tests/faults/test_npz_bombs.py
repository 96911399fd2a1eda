"""Input npz files (keypoints, a root trajectory, motion for ``train`` / ``motion info``, holosoma npy) are refused
from what their headers claim, before any array is allocated: a 2 kB file claiming 190 GiB, or zeros deflated
into megabytes, cost nothing. Pickled motion (Human3.6M) counts every array at its materialised size, so views
with zero strides of one small buffer cannot add up to gigabytes. The audit case (marker ``audit``) gives ``lift`` a
root trajectory claiming 180 GiB (:mod:`audit_support`)."""

from __future__ import annotations

import io
import pickle
import resource
import zipfile
from pathlib import Path

import numpy as np
import pytest
from audit_support import Case, Run, check_case, lift_args, openpose_copy

from platypose.detectors.sources.keypoint_files import read_keypoints_npz
from platypose.detectors.sources.root_file import read_root_trajectory
from platypose.lifting.errors import InputError
from platypose.lifting.motion_io import load_motion
from platypose.lifting.skeleton import JOINT_NAMES


def claiming(path: Path, shapes: dict[str, tuple[int, ...]], dtype: str = "<f8", **real: np.ndarray) -> Path:
    """An npz whose members named in ``shapes`` have a header claiming that shape and hold 16 bytes; ``real``
    members are written as they are."""
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        for name, shape in shapes.items():
            header = io.BytesIO()
            np.lib.format.write_array_header_1_0(header, {"descr": dtype, "fortran_order": False, "shape": shape})
            archive.writestr(f"{name}.npy", header.getvalue() + bytes(16))
        for name, value in real.items():
            stream = io.BytesIO()
            np.lib.format.write_array(stream, np.asarray(value))
            archive.writestr(f"{name}.npy", stream.getvalue())
    return path


def grown_kb(run) -> int:
    before = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    run()
    return resource.getrusage(resource.RUSAGE_SELF).ru_maxrss - before


def test_keypoint_npz_claiming_190_gib(tmp_path: Path) -> None:
    path = claiming(
        tmp_path / "kp.npz",
        {"keypoints2d": (1, 100, 10_000_000, 17, 3)},
        joint_names=np.array(JOINT_NAMES),
        frame_times=np.zeros(3),
    )
    assert path.stat().st_size < 4000

    def load() -> None:
        with pytest.raises(InputError, match=r"kp.npz: array 'keypoints2d' claims 380.0 GiB in its header, over the 1"):
            read_keypoints_npz(path)

    assert grown_kb(load) < 100_000


def test_root_trajectory_npz_claiming_too_much(tmp_path: Path) -> None:
    path = claiming(tmp_path / "root.npz", {"root": (60, 2**27, 3)}, frame_times=np.arange(3.0))
    with pytest.raises(InputError, match=r"root.npz: not a readable npz file \(array 'root' claims 180.0 GiB"):
        read_root_trajectory(path, np.arange(3.0), 1)


def test_two_arrays_within_the_bound_each_but_not_together(tmp_path: Path) -> None:
    half = (2**26 - 1, 2)  # just under 1 GiB each in float64
    path = claiming(tmp_path / "root.npz", {"root": half, "frame_times": half})
    with pytest.raises(InputError, match=r"its arrays claim 2.0 GiB, over the 1.5 GiB a file may hold"):
        read_root_trajectory(path, np.arange(3.0), 1)


def test_motion_npz_claiming_371_tib(tmp_path: Path) -> None:
    path = claiming(tmp_path / "motion.npz", {"joints": (2**40, 17, 3)}, fps=np.array(30.0))
    with pytest.raises(InputError, match=r"motion.npz: not a readable motion npz \(array 'joints' claims"):
        load_motion(path)


def test_holosoma_npy_claiming_too_much(tmp_path: Path) -> None:
    path = tmp_path / "climb.npy"
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False, "shape": (10**9, 53, 3)})
    path.write_bytes(header.getvalue() + bytes(16))
    from platypose.lifting.motion_io.holosoma import load_holosoma

    with pytest.raises(
        InputError, match=r"climb.npy: not a readable .npy array \(its header claims 1184.6 GiB, over the 1 GiB"
    ):
        load_holosoma(path)


class _View:
    """Pickles as numpy's ``ndarray(shape, dtype, buffer, offset, strides)``: a view with zero strides."""

    def __init__(self, rows: int, buffer: bytes) -> None:
        self.rows, self.buffer = rows, buffer

    def __reduce__(self):
        return (np.ndarray, ((self.rows, 32, 3), np.dtype("<f8"), self.buffer, 0, (0, 0, 0)))


def test_h36m_views_of_one_buffer_are_counted_at_their_full_size(tmp_path: Path) -> None:
    """40 views of one 8-byte buffer, each 0.18 GiB when materialised (7.3 GB in all), in a file of a few kB."""
    buffer = bytes(8)
    positions = {"S1": {f"Walk {i}": _View(250_000, buffer) for i in range(40)}}
    stream = pickle.dumps(np.array(positions, dtype=object), protocol=4)
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "|O", "fortran_order": False, "shape": ()})
    path = tmp_path / "data_3d_h36m.npz"
    with zipfile.ZipFile(path, "w", compression=zipfile.ZIP_DEFLATED) as archive:
        archive.writestr("positions_3d.npy", header.getvalue() + stream)
    assert path.stat().st_size < 10_000

    def load() -> None:
        with pytest.raises(InputError, match=r"its arrays come to more than 1.5 GiB when materialised"):
            load_motion(path)

    assert grown_kb(load) < 500_000


def _root_trajectory_claiming_180_gib(w: Path) -> Run:
    root = w / "root.npz"
    with zipfile.ZipFile(root, "w") as archive:
        header = io.BytesIO()
        np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False, "shape": (60, 2**27, 3)})
        archive.writestr("root.npy", header.getvalue() + bytes(16))
        stream = io.BytesIO()
        np.lib.format.write_array(stream, np.arange(3.0))
        archive.writestr("frame_times.npy", stream.getvalue())
    args = lift_args(openpose_copy(w), w / "out", "--root-trajectory", root)
    return Run(args, says=("root.npz", "claims 180.0 GiB in its header"))


@pytest.mark.audit
def test_lift_of_a_root_trajectory_npz_claiming_180_gib_is_a_clean_error(tmp_path: Path) -> None:
    check_case(Case("root-trajectory-npz-claiming-180-gib", _root_trajectory_claiming_180_gib), tmp_path)
