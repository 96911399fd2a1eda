"""Our npz/CSV keypoint files (read back independently), the minimal JSON schema, MMPose and COCO-style JSON.

No real MMPose output ships with our data, so those files are written here from the real
Pose2Sim OpenPose keypoints (BODY_25B's first 17 points are COCO-17 in COCO order).
"""

from __future__ import annotations

import csv
import json
from pathlib import Path

import numpy as np
import pytest

from platypose.detectors.sources.keypoint_files import (
    CSV_HEADER,
    read_keypoints_csv,
    read_keypoints_npz,
    write_keypoints_csv,
    write_keypoints_npz,
)
from platypose.detectors.sources.keypoint_source import read_keypoints
from platypose.detectors.sources.openpose import read_openpose_folder
from platypose.lifting.errors import InputError
from platypose.lifting.skeleton import JOINT_INDEX, JOINT_NAMES

SIZE = (1920, 1080)
NOT_NECK = [j for j in range(17) if j != JOINT_INDEX["neck"]]  # BODY_25B has its own neck point


@pytest.fixture(scope="module")
def cam01_json(data_dir: Path) -> Path:
    return data_dir / "video/pose2sim-balancing/openpose-body25b/cam01_json"


@pytest.fixture(scope="module")
def tracks(cam01_json: Path):
    return read_openpose_folder(cam01_json)


@pytest.fixture(scope="module")
def raw_frames(cam01_json: Path) -> list[list[list[float]]]:
    """Per frame, the raw BODY_25B people as flat lists, in file order."""
    return [
        [p["pose_keypoints_2d"] for p in json.loads(path.read_text())["people"]]
        for path in sorted(cam01_json.glob("*.json"))
    ]


def test_npz_round_trip_read_independently(tracks, tmp_path: Path) -> None:
    path = write_keypoints_npz(tracks, tmp_path / "cam01.npz")
    with np.load(path) as data:
        assert data["keypoints2d"].shape == (1, tracks.num_persons, 100, 17, 3)
        np.testing.assert_array_equal(data["keypoints2d"][0].transpose(1, 0, 2, 3), tracks.keypoints)
        assert data["joint_names"].tolist() == list(JOINT_NAMES)
        assert data["image_size"].tolist() == list(SIZE)
        np.testing.assert_allclose(data["frame_times"][1], 1 / 60)
    back = read_keypoints(path)
    np.testing.assert_array_equal(back.keypoints, tracks.keypoints)
    assert back.image_size == SIZE and back.track_ids.tolist() == tracks.track_ids.tolist()
    assert list(tmp_path.iterdir()) == [path]  # no temp file left behind


def test_csv_round_trip_read_independently(tracks, tmp_path: Path) -> None:
    path = write_keypoints_csv(tracks, tmp_path / "cam01.csv")
    with open(path, newline="") as stream:
        rows = list(csv.DictReader(stream))
    assert tuple(rows[0]) == CSV_HEADER
    assert len(rows) == tracks.num_persons * 100 * 17
    row = next(r for r in rows if r["person"] == "0" and r["frame"] == "3" and r["joint"] == "right_knee")
    expected = tracks.keypoints[3, 0, JOINT_INDEX["right_knee"]]
    assert float(row["x"]) == pytest.approx(expected[0], abs=1e-3)
    assert float(row["y"]) == pytest.approx(expected[1], abs=1e-3)
    assert float(row["time"]) == pytest.approx(3 / 60, abs=1e-6)
    missing = [r for r in rows if float(r["confidence"]) == 0]
    assert missing and all(r["x"] == "" and r["y"] == "" for r in missing)
    back = read_keypoints(path, image_size=SIZE)
    np.testing.assert_allclose(back.keypoints, tracks.keypoints, atol=1e-3, equal_nan=True)
    np.testing.assert_allclose(back.frame_times, tracks.frame_times, atol=1e-6)


def test_minimal_schema_with_and_without_ids(tracks, raw_frames, tmp_path: Path) -> None:
    def write(with_ids: bool) -> Path:
        frames = [
            {
                "frame": n,
                "people": [
                    {**({"id": 10 + i} if with_ids else {}), "keypoints": np.reshape(flat, (25, 3)).tolist()}
                    for i, flat in enumerate(people)
                ],
            }
            for n, people in enumerate(raw_frames)
            if n != 50  # frame 50 left out: a stated gap
        ]
        content = {
            "format": "platypose-keypoints2d",
            "version": 1,
            "fps": 60,
            "image_size": list(SIZE),
            "layout": "body25b",
            "frames": frames,
        }
        path = tmp_path / f"mine_{with_ids}.json"
        path.write_text(json.dumps(content))
        return path

    tracked = read_keypoints(write(False))
    assert tracked.num_frames == 100 and (tracked.keypoints[50, ..., 2] == 0).all()
    keep = [t for t in range(100) if t != 50]
    np.testing.assert_allclose(tracked.keypoints[keep], tracks.keypoints[keep], equal_nan=True)
    with_ids = read_keypoints(write(True))
    assert with_ids.track_ids.min() >= 10  # the file's own IDs are kept
    first = np.array(raw_frames[0][0]).reshape(25, 3)
    column = with_ids.track_ids.tolist().index(10)
    np.testing.assert_allclose(with_ids.keypoints[0, column, JOINT_INDEX["left_ankle"]], first[15], rtol=1e-6)


def test_mmpose_predictions_and_coco_style(tracks, raw_frames, tmp_path: Path) -> None:
    instances_per_frame = []
    for people in raw_frames:
        instances = []
        for flat in people:
            points = np.reshape(flat, (25, 3))[:17]
            instances.append(
                {
                    "keypoints": points[:, :2].tolist(),
                    "keypoint_scores": points[:, 2].tolist(),
                    "bbox": [[0, 0, 10, 10]],
                    "bbox_score": 0.9,
                }
            )
        instances_per_frame.append(instances)
    predictions = tmp_path / "cam01.json"
    predictions.write_text(
        json.dumps(
            {
                "meta_info": {"dataset_name": "coco"},
                "instance_info": [{"frame_id": n + 1, "instances": inst} for n, inst in enumerate(instances_per_frame)],
            }
        )
    )
    mm = read_keypoints(predictions, fps=60, image_size=SIZE)
    assert mm.frame_times[0] == 0 and mm.frame_times[1] == pytest.approx(1 / 60)
    np.testing.assert_allclose(
        mm.keypoints[:, :, NOT_NECK], tracks.keypoints[:, :, NOT_NECK], rtol=1e-5, equal_nan=True
    )
    coco = {
        "images": [{"id": 100 + n, "frame_id": n, "width": SIZE[1], "height": SIZE[0]} for n in range(100)],
        "annotations": [
            {
                "image_id": 100 + n,
                "track_id": i,
                "num_keypoints": 17,
                "keypoints": np.column_stack(
                    [np.reshape(flat, (25, 3))[:17, :2], 2 * (np.reshape(flat, (25, 3))[:17, 2] > 0)]
                )
                .ravel()
                .tolist(),
            }
            for n, people in enumerate(raw_frames)
            for i, flat in enumerate(people)
        ],
    }
    coco_path = tmp_path / "posetrack.json"
    coco_path.write_text(json.dumps(coco))
    posetrack = read_keypoints(coco_path, fps=60)
    assert posetrack.image_size == SIZE  # from the images
    assert posetrack.track_ids.tolist() == [0, 1, 2]  # the file's IDs (one frame of cam01 has 3 people)
    seen = posetrack.keypoints[..., 2] > 0
    assert set(np.unique(posetrack.keypoints[..., 2][seen])) == {1.0}  # visibility flags -> confidence 1


def test_bad_files(tmp_path: Path) -> None:
    bad_npz = tmp_path / "x.npz"
    np.savez(bad_npz, something=np.zeros(3))
    with pytest.raises(InputError, match=r"x\.npz: no 'keypoints2d'"):
        read_keypoints_npz(bad_npz)
    bad_csv = tmp_path / "x.csv"
    bad_csv.write_text("a,b,c\n1,2,3\n")
    with pytest.raises(InputError, match=r"x\.csv: header must be"):
        read_keypoints_csv(bad_csv, image_size=SIZE)
    odd = tmp_path / "odd.json"
    odd.write_text(json.dumps({"hello": 1}))
    with pytest.raises(InputError, match=r"odd\.json: not MMPose or COCO-style"):
        read_keypoints(odd, fps=30, image_size=SIZE)
    mixed = tmp_path / "mixed.json"
    mixed.write_text(
        json.dumps(
            {
                "format": "platypose-keypoints2d",
                "fps": 30,
                "image_size": [10, 10],
                "layout": "platypose17",
                "frames": [
                    {"frame": 0, "people": [{"id": 1, "keypoints": [[1, 1, 1]] * 17}, {"keypoints": [[5, 5, 1]] * 17}]}
                ],
            }
        )
    )
    with pytest.raises(InputError, match="id for every person or for none"):
        read_keypoints(mixed)
    wrong_count = tmp_path / "short.json"
    wrong_count.write_text(
        json.dumps(
            {
                "format": "platypose-keypoints2d",
                "fps": 30,
                "image_size": [10, 10],
                "layout": "coco17",
                "frames": [{"frame": 0, "people": [{"keypoints": [[1, 1, 1]] * 12}]}],
            }
        )
    )
    with pytest.raises(InputError, match="layout coco17 has 17 points per person"):
        read_keypoints(wrong_count)
    with pytest.raises(InputError, match="unknown keypoint file type"):
        read_keypoints(_touch(tmp_path / "a.txt"))


def _touch(path: Path) -> Path:
    path.write_text("")
    return path
