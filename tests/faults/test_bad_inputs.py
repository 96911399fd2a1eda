"""Real files corrupted in tmp_path give one-line InputErrors naming the file, never
a traceback, a hang or a silently wrong result."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import numpy as np
import pytest

from platypose.detectors.sources.keypoint_files import read_keypoints_csv, read_keypoints_npz, write_keypoints_csv
from platypose.detectors.sources.keypoint_json import read_keypoints_json
from platypose.detectors.sources.openpose import read_openpose_folder
from platypose.lifting.errors import InputError
from platypose.lifting.motion_io import load_motion

OPENPOSE = "video/pose2sim-balancing/openpose-body25b/cam01_json"
SIZE = (1920, 1080)  # the portrait cam01 video: height, width
BVH = "motion/mocapbank/test_mocapbank.bvh"


def openpose_copy(data_dir: Path, tmp_path: Path, count: int = 4) -> Path:
    """The first ``count`` frames of the real OpenPose BODY_25B folder of cam01, copied."""
    folder = tmp_path / "cam01_json"
    folder.mkdir()
    for path in sorted((data_dir / OPENPOSE).glob("*.json"))[:count]:
        shutil.copy(path, folder / path.name)
    return folder


def edit_json(path: Path, change) -> None:
    content = json.loads(path.read_text())
    change(content)
    path.write_text(json.dumps(content))


def test_real_openpose_copy_reads(data_dir, tmp_path):
    tracks = read_openpose_folder(openpose_copy(data_dir, tmp_path), fps=60, image_size=SIZE)
    assert tracks.num_frames == 4 and tracks.num_persons >= 1


def test_misnumbered_openpose_file_is_named_not_100_million_frames(data_dir, tmp_path):
    folder = openpose_copy(data_dir, tmp_path)
    (folder / "cam01.0003.json").rename(folder / "cam01.99999999.json")
    with pytest.raises(InputError, match=r"cam01\.99999999\.json \(frame 99999999\) comes 99999997 frames after"):
        read_openpose_folder(folder, fps=60, image_size=SIZE)


def test_a_stated_gap_rule_keeps_ordinary_gaps(data_dir, tmp_path):
    folder = openpose_copy(data_dir, tmp_path)
    (folder / "cam01.0003.json").rename(folder / "cam01.0500.json")  # 496 frames without a file: kept, empty
    tracks = read_openpose_folder(folder, fps=60, image_size=SIZE)
    assert tracks.num_frames == 501 and not (tracks.keypoints[3:500, ..., 2] > 0).any()


@pytest.mark.parametrize(
    "value, match", [(1e30, "far outside the 1080x1920 image"), (-5000.0, "far outside"), (float("nan"), "far outside")]
)
def test_openpose_points_far_outside_the_image(data_dir, tmp_path, value, match):
    folder = openpose_copy(data_dir, tmp_path)

    def change(content):
        content["people"][0]["pose_keypoints_2d"][0] = value  # x of the first point (confidence 0.66)

    edit_json(folder / "cam01.0002.json", change)
    with pytest.raises(InputError, match=rf"cam01_json: frame 2: keypoint .*{match}"):
        read_openpose_folder(folder, fps=60, image_size=SIZE)


def test_600_people_in_a_frame_is_refused_quickly(data_dir, tmp_path):
    folder = openpose_copy(data_dir, tmp_path)
    edit_json(folder / "cam01.0001.json", lambda c: c.__setitem__("people", c["people"][:1] * 600))
    with pytest.raises(InputError, match="frame 1 has 600 people; at most 100"):
        read_openpose_folder(folder, fps=60, image_size=SIZE)


@pytest.mark.parametrize(
    "fps, size, match",
    [
        (float("inf"), SIZE, "fps must be a number from 1 to 10000, got inf"),
        (0.0, SIZE, "fps must be a number from 1 to 10000, got 0.0"),
        (1e-300, SIZE, "fps must be a number from 1 to 10000, got 1e-300"),  # was read, and found no person
        (float("nan"), SIZE, "fps must be a number from 1 to 10000, got nan"),
        (60.0, (0, 0), "image size 0x0"),
        (60.0, (1920, -4), "image size 1920x-4"),
    ],
)
def test_openpose_timing_options(data_dir, tmp_path, fps, size, match):
    with pytest.raises(InputError, match=match):
        read_openpose_folder(openpose_copy(data_dir, tmp_path), fps=fps, image_size=size)


def minimal_json(data_dir: Path, tmp_path: Path, **override) -> Path:
    """The real OpenPose frames of cam01 rewritten in our minimal JSON schema (BODY_25B layout)."""
    frames = []
    for n, path in enumerate(sorted((data_dir / OPENPOSE).glob("*.json"))[:4]):
        people = json.loads(path.read_text())["people"]
        points = [np.reshape(p["pose_keypoints_2d"], (-1, 3)).tolist() for p in people]
        frames.append({"frame": n, "people": [{"keypoints": k} for k in points]})
    content = {"format": "platypose-keypoints2d", "version": 1, "fps": 60.0, "image_size": list(SIZE)}
    content.update(layout="body25b", frames=frames)
    content.update(override)
    path = tmp_path / "cam01.json"
    path.write_text(json.dumps(content))
    return path


def test_minimal_json_reads(data_dir, tmp_path):
    assert read_keypoints_json(minimal_json(data_dir, tmp_path)).num_frames == 4


def test_fractional_frame_numbers_are_refused(data_dir, tmp_path):
    path = minimal_json(data_dir, tmp_path)
    edit_json(path, lambda c: c["frames"][1].__setitem__("frame", 1.5))
    with pytest.raises(InputError, match=r"cam01\.json: .*frame number 1\.5 is not a whole number"):
        read_keypoints_json(path)


@pytest.mark.parametrize(
    "override, match",
    [({"image_size": [0, 0]}, "image size 0x0"), ({"fps": 1e400}, "fps must be"), ({"fps": 0}, "fps must be")],
)
def test_minimal_json_bad_header(data_dir, tmp_path, override, match):
    with pytest.raises(InputError, match=match):
        read_keypoints_json(minimal_json(data_dir, tmp_path, **override))


@pytest.fixture
def real_csv(data_dir, tmp_path) -> Path:
    tracks = read_openpose_folder(openpose_copy(data_dir, tmp_path), fps=60, image_size=SIZE)
    return write_keypoints_csv(tracks, tmp_path / "cam01_keypoints2d.csv")


def test_short_csv_row_names_the_row(real_csv):
    lines = real_csv.read_text().splitlines()
    lines[5] = ",".join(lines[5].split(",")[:4])
    real_csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"cam01_keypoints2d\.csv: row 6 has 4 values, not 7"):
        read_keypoints_csv(real_csv, SIZE)


def test_csv_with_zero_frame_times(real_csv):
    rows = [line.split(",") for line in real_csv.read_text().splitlines()]
    for row in rows[1:]:
        row[2] = "0.000000"
    real_csv.write_text("\n".join(",".join(r) for r in rows) + "\n")
    with pytest.raises(InputError, match="frame times must be finite and increasing"):
        read_keypoints_csv(real_csv, SIZE)


def test_csv_point_at_1e30(real_csv):
    rows = [line.split(",") for line in real_csv.read_text().splitlines()]
    seen = next(r for r in rows[1:] if r[4])
    seen[4] = "1e30"
    real_csv.write_text("\n".join(",".join(r) for r in rows) + "\n")
    with pytest.raises(InputError, match="far outside"):
        read_keypoints_csv(real_csv, SIZE)


def test_csv_frame_index_far_away_is_refused_without_allocating(real_csv):
    rows = [line.split(",") for line in real_csv.read_text().splitlines()]
    rows[-1][1] = "99999999"
    real_csv.write_text("\n".join(",".join(r) for r in rows) + "\n")
    with pytest.raises(InputError, match="not contiguous"):
        read_keypoints_csv(real_csv, SIZE)


def test_zero_byte_npz_readers(tmp_path):
    from platypose.exporters.npz import read_npz

    empty = tmp_path / "cam01_keypoints2d.npz"
    empty.write_bytes(b"")
    with pytest.raises(InputError, match="cam01_keypoints2d.npz: empty or truncated"):
        read_keypoints_npz(empty)
    with pytest.raises(InputError, match="cam01_keypoints2d.npz: empty or truncated"):
        read_npz(empty)


@pytest.mark.parametrize("command", ["info", "detect"])
def test_zero_byte_npz_in_detect_and_info_is_one_line(run_cli, tmp_path, command):
    empty = tmp_path / "cam01_keypoints2d.npz"
    empty.write_bytes(b"")
    args = (command, empty) if command == "info" else (command, empty, "--out", tmp_path / "out", "--fps", "60")
    code, _, err = run_cli(*args)
    assert code == 2 and err.strip().startswith("error:") and "empty or truncated" in err and "Abort" not in err


def corrupt_bvh(data_dir: Path, tmp_path: Path, value: str, frame: int = 3) -> Path:
    """The real mocapbank BVH with one channel value of ``frame`` replaced by ``value``."""
    text = (data_dir / BVH).read_text()
    head, motion = text.split("MOTION", 1)
    lines = motion.splitlines()
    start = next(i for i, line in enumerate(lines) if line.startswith("Frame Time")) + 1
    values = lines[start + frame].split()
    values[0] = value  # the root's first position channel
    lines[start + frame] = " ".join(values)
    path = tmp_path / "broken.bvh"
    path.write_text(head + "MOTION" + "\n".join(lines) + "\n")
    return path


@pytest.mark.parametrize("value", ["1e308", "1e30", "inf", "-1e12"])
def test_bvh_with_an_absurd_frame_is_refused_naming_the_frame(data_dir, tmp_path, value):
    with pytest.raises(InputError, match=r"broken\.bvh: .*frame 3 .*(from the origin|not a number|NaN or infinite)"):
        load_motion(corrupt_bvh(data_dir, tmp_path, value))


def test_bvh_unchanged_still_loads(data_dir, tmp_path):
    text = (data_dir / BVH).read_text()
    (motion,) = load_motion(corrupt_bvh(data_dir, tmp_path, text.split("MOTION")[1].splitlines()[3].split()[0]))
    assert np.isfinite(motion.joints).all()


def test_train_on_the_1e308_bvh_is_one_line_and_writes_no_prior(run_cli, data_dir, tmp_path):
    out = tmp_path / "prior.pt"
    code, _, err = run_cli("train", corrupt_bvh(data_dir, tmp_path, "1e308"), "--out", out, "--iterations", "2")
    assert code == 2 and "broken.bvh" in err and "frame 3" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()
