"""Plain npz and Human3.6M VideoPose3D npz importers, on files written here from real clips."""

from __future__ import annotations

import numpy as np
import pytest
from motion_sanity import assert_plausible

from platypose.lifting.errors import InputError
from platypose.lifting.joint_maps import H36M32_TO_OURS
from platypose.lifting.motion_io import load_motion
from platypose.lifting.skeleton import JOINT_NAMES


@pytest.fixture(scope="module")
def cmu(data_dir):
    return load_motion(data_dir / "motion/cmu-asf-amc/test.amc")[0]


def test_plain_npz_round_trip_with_reordered_names(tmp_path, cmu):
    order = np.random.default_rng(0).permutation(17)
    path = tmp_path / "clip.npz"
    np.savez(path, joints=cmu.joints[:300, order], fps=120.0, joint_names=np.array(JOINT_NAMES)[order])
    (m,) = load_motion(path)
    assert m.fps == 120.0 and m.name == "clip" and m.licence == "unknown"
    np.testing.assert_array_equal(m.joints, cmu.joints[:300])


def test_plain_npz_errors(tmp_path, cmu):
    no_fps = tmp_path / "nofps.npz"
    np.savez(no_fps, joints=cmu.joints[:10])
    with pytest.raises(InputError, match="nofps.npz.*fps"):
        load_motion(no_fps)
    assert load_motion(no_fps, fps=25)[0].fps == 25
    shape = tmp_path / "shape.npz"
    np.savez(shape, joints=np.zeros((10, 16, 3)), fps=30)
    with pytest.raises(InputError, match=r"shape.npz.*\(T, 17, 3\)"):
        load_motion(shape)
    other = tmp_path / "other.npz"
    np.savez(other, poses=np.zeros(3))
    with pytest.raises(InputError, match="other.npz.*not a valid"):
        load_motion(other)
    broken = tmp_path / "broken.npz"
    broken.write_bytes(b"PK\x03\x04 not really a zip")
    with pytest.raises(InputError, match="broken.npz"):
        load_motion(broken)


def write_h36m(path, clips: dict[str, dict[str, np.ndarray]]) -> None:
    """Write the VideoPose3D layout: a pickled {subject: {action: (T, 32, 3)}} under positions_3d."""
    np.savez_compressed(path, positions_3d=np.array(clips, dtype=object))


def to_32(joints17: np.ndarray) -> np.ndarray:
    """Place our 17 joints at their H36M slots; the 15 other slots get far-away filler."""
    out = np.full((joints17.shape[0], 32, 3), 99.0)
    out[:, list(H36M32_TO_OURS)] = joints17
    return out


def test_h36m_layout_gives_one_clip_per_subject_action(tmp_path, cmu):
    path = tmp_path / "data_3d_h36m.npz"
    write_h36m(
        path,
        {
            "S9": {"Walking": to_32(cmu.joints[:200])},
            "S1": {"Walking 1": to_32(cmu.joints[200:300]), "Directions": to_32(cmu.joints[300:350])},
        },
    )
    clips = load_motion(path)
    assert [c.name for c in clips] == [
        "data_3d_h36m/S1/Directions",
        "data_3d_h36m/S1/Walking 1",
        "data_3d_h36m/S9/Walking",
    ]
    assert [c.num_frames for c in clips] == [50, 100, 200]
    assert all(c.fps == 50.0 for c in clips)
    np.testing.assert_array_equal(clips[2].joints, cmu.joints[:200])
    assert clips[1].extra["subject"] == "S1" and clips[1].extra["action"] == "Walking 1"
    assert_plausible(clips[2], rigid_tol_m=1e-6, min_head_rise_m=0.5)


def test_h36m_index_map_picks_the_standard_slots(tmp_path):
    slots = np.tile(np.arange(32, dtype=float)[None, :, None], (4, 1, 3)) * 0.01  # slot k at k cm
    path = tmp_path / "slots.npz"
    write_h36m(path, {"S1": {"A": slots}})
    (m,) = load_motion(path)
    assert np.round(m.joints[0, :, 0] * 100).tolist() == [0, 1, 2, 3, 6, 7, 8, 12, 13, 14, 15, 17, 18, 19, 25, 26, 27]


def test_h36m_bad_clip_named(tmp_path):
    path = tmp_path / "bad_h36m.npz"
    write_h36m(path, {"S1": {"Eating": np.zeros((5, 17, 3))}})
    with pytest.raises(InputError, match="bad_h36m.npz.*S1/Eating.*32"):
        load_motion(path)


class _RunsCode:
    """An object whose unpickling calls a function of the file's choosing (here: creating a marker file)."""

    def __init__(self, marker: str) -> None:
        self.marker = marker

    def __reduce__(self):
        return (open, (self.marker, "w"))


@pytest.mark.parametrize(
    "args",
    [["motion", "info", "{folder}/data_3d_h36m.npz"], ["train", "{folder}", "--iterations", "1", "--out", "prior.pt"]],
    ids=["motion-info", "train-folder-scan"],
)
def test_h36m_npz_that_would_run_code_is_refused_and_nothing_runs(tmp_path, monkeypatch, run_cli, args):
    marker = tmp_path / "ran"
    folder = tmp_path / "mocap"
    folder.mkdir()
    np.savez(folder / "data_3d_h36m.npz", positions_3d=np.array({"S1": {"Walking": _RunsCode(str(marker))}}))
    with pytest.raises(InputError, match=r"data_3d_h36m.npz.*refused to load .*open.*not loaded"):
        load_motion(folder / "data_3d_h36m.npz")
    monkeypatch.chdir(tmp_path)
    code, _, err = run_cli(*[a.format(folder=folder) for a in args])
    assert code == 2, err
    assert "data_3d_h36m.npz" in err and "not loaded" in err
    assert not marker.exists() and not (tmp_path / "prior.pt").exists()


def test_h36m_layout_written_by_numpy_1_still_loads(tmp_path):
    """VideoPose3D's files were written by numpy 1 (pickles naming numpy.core.multiarray; protocol 2 stores bytes via _codecs)."""
    import io
    import pickle
    import zipfile

    points = np.random.default_rng(0).normal(size=(3, 32, 3)) * 0.2  # joints within a metre or so
    stream = pickle.dumps(np.array({"S1": {"A": points}}, dtype=object), protocol=2)
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "|O", "fortran_order": False, "shape": ()})
    path = tmp_path / "old.npz"
    with zipfile.ZipFile(path, "w") as archive:
        archive.writestr("positions_3d.npy", header.getvalue() + stream.replace(b"numpy._core.", b"numpy.core."))
    (m,) = load_motion(path)
    np.testing.assert_array_equal(m.joints, points[:, list(H36M32_TO_OURS)])
