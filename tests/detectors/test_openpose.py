"""OpenPose JSON folders: the real Pose2Sim BODY_25B files, layout guessing, gaps and bad input."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from platypose.detectors.sources.openpose import missing_frames, read_openpose_folder
from platypose.lifting.errors import InputError
from platypose.lifting.joint_maps import BODY25_NAMES, BODY25B_NAMES
from platypose.lifting.skeleton import JOINT_INDEX


@pytest.fixture(scope="module")
def cam01_json(data_dir: Path) -> Path:
    return data_dir / "video/pose2sim-balancing/openpose-body25b/cam01_json"


def _raw_people(path: Path) -> np.ndarray:
    return np.array([p["pose_keypoints_2d"] for p in json.loads(path.read_text())["people"]]).reshape(-1, 25, 3)


def test_real_body25b_folder(cam01_json: Path) -> None:
    tracks = read_openpose_folder(cam01_json)
    assert tracks.keypoints.shape == (100, 2, 17, 3)
    assert tracks.image_size == (1920, 1080)  # from cam01.mp4 one level up
    np.testing.assert_allclose(tracks.frame_times[:3], [0, 1 / 60, 2 / 60])
    # frame 0: every tracked person is one of the raw people, joint for joint
    raw = _raw_people(cam01_json / "cam01.0000.json")
    for person in tracks.keypoints[0]:
        match = np.argmin(np.abs(raw[:, BODY25B_NAMES.index("right_ankle"), 0] - person[JOINT_INDEX["right_ankle"], 0]))
        np.testing.assert_allclose(person[JOINT_INDEX["right_ankle"]], raw[match, 16], rtol=1e-6)
        np.testing.assert_allclose(person[JOINT_INDEX["neck"], :2], raw[match, 17, :2], rtol=1e-6)
        hips = raw[match, 11:13]
        pelvis = hips[:, :2].mean(axis=0) if (hips[:, 2] > 0).all() else [np.nan, np.nan]
        np.testing.assert_allclose(person[JOINT_INDEX["pelvis"], :2], pelvis, rtol=1e-6)
        assert person[JOINT_INDEX["pelvis"], 2] == pytest.approx(hips[:, 2].min(), rel=1e-6)
    # the main person (the big one in the middle) is one track seen in nearly every frame
    seen = (tracks.keypoints[..., 2] > 0).any(axis=2).mean(axis=0)
    assert seen.max() > 0.95


def test_missing_points_become_nan(cam01_json: Path) -> None:
    tracks = read_openpose_folder(cam01_json)
    missing = tracks.keypoints[..., 2] == 0
    assert missing.any()
    assert np.isnan(tracks.keypoints[..., :2][missing]).all()
    assert np.isfinite(tracks.keypoints[..., :2][~missing]).all()


def test_body25_order_gives_same_tracks(cam01_json: Path, tmp_path: Path) -> None:
    """The same real points rewritten in BODY_25 order are recognised as BODY_25 and map to the same joints."""
    folder = tmp_path / "cam01_json"
    folder.mkdir()
    order = [BODY25B_NAMES.index(name) if name in BODY25B_NAMES else None for name in BODY25_NAMES]
    for path in sorted(cam01_json.glob("*.json"))[:20]:
        people = []
        for raw in _raw_people(path):
            body25 = np.array([raw[i] if i is not None else (0.0, 0.0, 0.0) for i in order])
            people.append({"person_id": [-1], "pose_keypoints_2d": body25.ravel().tolist()})
        (folder / path.name).write_text(json.dumps({"version": 1.3, "people": people}))
    original = read_openpose_folder(cam01_json, fps=60, image_size=(1920, 1080), layout="body25b")
    rewritten = read_openpose_folder(folder, fps=60, image_size=(1920, 1080))
    assert rewritten.num_persons == 2
    neck = JOINT_INDEX["neck"]
    others = [j for j in range(17) if j != neck]  # BODY_25B's neck is its own upper-neck point
    np.testing.assert_allclose(
        rewritten.keypoints[:, :, others], original.keypoints[:20, :, others], rtol=1e-6, equal_nan=True
    )


def test_gap_in_frame_numbers_is_kept_as_missing_frames(cam01_json: Path, tmp_path: Path) -> None:
    folder = tmp_path / "cam01_json"
    shutil.copytree(cam01_json, folder)
    (folder / "cam01.0010.json").unlink()
    (folder / "cam01.0011.json").unlink()
    assert missing_frames(folder).tolist() == [10, 11]
    tracks = read_openpose_folder(folder, fps=60, image_size=(1920, 1080))
    assert tracks.num_frames == 100
    assert (tracks.keypoints[10:12, ..., 2] == 0).all()
    assert np.isnan(tracks.keypoints[10:12, ..., :2]).all()
    assert tracks.frame_times[12] == pytest.approx(12 / 60)
    assert (tracks.keypoints[12, :, :, 2] > 0).any()
    # the gap is bridged: the main person keeps one ID across it
    assert (tracks.keypoints[:, :, :, 2] > 0).any(axis=2).sum(axis=0).max() >= 95


def test_bad_inputs(cam01_json: Path, tmp_path: Path) -> None:
    with pytest.raises(InputError, match="not a folder"):
        read_openpose_folder(tmp_path / "nope", fps=30, image_size=(10, 10))
    with pytest.raises(InputError, match="no .json files"):
        read_openpose_folder(tmp_path, fps=30, image_size=(10, 10))
    broken = tmp_path / "broken_json"
    shutil.copytree(cam01_json, broken)
    (broken / "cam01.0005.json").write_text("{not json")
    with pytest.raises(InputError, match=r"cam01\.0005\.json: not an OpenPose keypoint file"):
        read_openpose_folder(broken, fps=30, image_size=(10, 10))
    with pytest.raises(InputError, match="no video beside it"):
        read_openpose_folder(broken)
    odd = tmp_path / "odd_json"
    odd.mkdir()
    (odd / "f_0001.json").write_text(json.dumps({"people": [{"pose_keypoints_2d": [1.0] * 30}]}))
    with pytest.raises(InputError, match="10 keypoints per person match no known layout"):
        read_openpose_folder(odd, fps=30, image_size=(10, 10))
