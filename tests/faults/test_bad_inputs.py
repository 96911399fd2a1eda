"""Bad input files: real keypoints (OpenPose folders, our JSON and CSV, npz), BVH motion and videos, corrupted in
tmp_path, give one-line InputErrors naming the file, never a traceback, a hang or a silently wrong result. The audit
cases (marker ``audit``, run with ``pytest -m audit``) give such files to the real CLI (``detect``, ``lift``,
``motion info``), each ending in a clean error or handled well (:mod:`audit_support`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from audit_support import (
    BVH,
    FAST,
    KEYPOINT_TIMING,
    Case,
    Run,
    check_case,
    corrupt_bvh,
    edit_json,
    minimal_json,
    openpose_copy,
    real_csv,
    registry,
    rewrite_csv,
    summary,
    truncated_video,
)

from platypose.detectors.sources.keypoint_files import read_keypoints_csv, read_keypoints_npz, write_keypoints_csv
from platypose.detectors.sources.keypoint_json import read_keypoints_json
from platypose.detectors.sources.openpose import read_openpose_folder
from platypose.lifting.errors import InputError
from platypose.lifting.motion_io import load_motion

SIZE = (1920, 1080)  # the portrait cam01 video: height, width


def test_real_openpose_copy_reads(tmp_path):
    tracks = read_openpose_folder(openpose_copy(tmp_path, frames=4), fps=60, image_size=SIZE)
    assert tracks.num_frames == 4 and tracks.num_persons >= 1


def test_misnumbered_openpose_file_is_named_not_100_million_frames(tmp_path):
    folder = openpose_copy(tmp_path, frames=4)
    (folder / "cam01.0003.json").rename(folder / "cam01.99999999.json")
    with pytest.raises(InputError, match=r"cam01\.99999999\.json \(frame 99999999\) comes 99999997 frames after"):
        read_openpose_folder(folder, fps=60, image_size=SIZE)


def test_a_stated_gap_rule_keeps_ordinary_gaps(tmp_path):
    folder = openpose_copy(tmp_path, frames=4)
    (folder / "cam01.0003.json").rename(folder / "cam01.0500.json")  # 496 frames without a file: kept, empty
    tracks = read_openpose_folder(folder, fps=60, image_size=SIZE)
    assert tracks.num_frames == 501 and not (tracks.keypoints[3:500, ..., 2] > 0).any()


@pytest.mark.parametrize(
    "value, match", [(1e30, "far outside the 1080x1920 image"), (-5000.0, "far outside"), (float("nan"), "far outside")]
)
def test_openpose_points_far_outside_the_image(tmp_path, value, match):
    folder = openpose_copy(tmp_path, frames=4)

    def change(content):
        content["people"][0]["pose_keypoints_2d"][0] = value  # x of the first point (confidence 0.66)

    edit_json(folder / "cam01.0002.json", change)
    with pytest.raises(InputError, match=rf"cam01_json: frame 2: keypoint .*{match}"):
        read_openpose_folder(folder, fps=60, image_size=SIZE)


def test_600_people_in_a_frame_is_refused_quickly(tmp_path):
    folder = openpose_copy(tmp_path, frames=4)
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
def test_openpose_timing_options(tmp_path, fps, size, match):
    with pytest.raises(InputError, match=match):
        read_openpose_folder(openpose_copy(tmp_path, frames=4), fps=fps, image_size=size)


def cam01_json(tmp_path: Path, **override) -> Path:
    """The first 4 real cam01 OpenPose frames in the minimal JSON schema, at the portrait video's size."""
    return minimal_json(tmp_path, 4, **{"image_size": list(SIZE), **override})


def test_minimal_json_reads(tmp_path):
    assert read_keypoints_json(cam01_json(tmp_path)).num_frames == 4


def test_fractional_frame_numbers_are_refused(tmp_path):
    path = cam01_json(tmp_path)
    edit_json(path, lambda c: c["frames"][1].__setitem__("frame", 1.5))
    with pytest.raises(InputError, match=r"cam01\.json: .*frame number 1\.5 is not a whole number"):
        read_keypoints_json(path)


@pytest.mark.parametrize(
    "override, match",
    [({"image_size": [0, 0]}, "image size 0x0"), ({"fps": 1e400}, "fps must be"), ({"fps": 0}, "fps must be")],
)
def test_minimal_json_bad_header(tmp_path, override, match):
    with pytest.raises(InputError, match=match):
        read_keypoints_json(cam01_json(tmp_path, **override))


@pytest.fixture
def cam01_csv(tmp_path) -> Path:
    tracks = read_openpose_folder(openpose_copy(tmp_path, frames=4), fps=60, image_size=SIZE)
    return write_keypoints_csv(tracks, tmp_path / "cam01_keypoints2d.csv")


def test_short_csv_row_names_the_row(cam01_csv):
    lines = cam01_csv.read_text().splitlines()
    lines[5] = ",".join(lines[5].split(",")[:4])
    cam01_csv.write_text("\n".join(lines) + "\n")
    with pytest.raises(InputError, match=r"cam01_keypoints2d\.csv: row 6 has 4 values, not 7"):
        read_keypoints_csv(cam01_csv, SIZE)


def test_csv_with_zero_frame_times(cam01_csv):
    rows = [line.split(",") for line in cam01_csv.read_text().splitlines()]
    for row in rows[1:]:
        row[2] = "0.000000"
    cam01_csv.write_text("\n".join(",".join(r) for r in rows) + "\n")
    with pytest.raises(InputError, match="frame times must be finite and increasing"):
        read_keypoints_csv(cam01_csv, SIZE)


def test_csv_point_at_1e30(cam01_csv):
    rows = [line.split(",") for line in cam01_csv.read_text().splitlines()]
    seen = next(r for r in rows[1:] if r[4])
    seen[4] = "1e30"
    cam01_csv.write_text("\n".join(",".join(r) for r in rows) + "\n")
    with pytest.raises(InputError, match="far outside"):
        read_keypoints_csv(cam01_csv, SIZE)


def test_csv_frame_index_far_away_is_refused_without_allocating(cam01_csv):
    rows = [line.split(",") for line in cam01_csv.read_text().splitlines()]
    rows[-1][1] = "99999999"
    cam01_csv.write_text("\n".join(",".join(r) for r in rows) + "\n")
    with pytest.raises(InputError, match="not contiguous"):
        read_keypoints_csv(cam01_csv, SIZE)


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
    assert code == 2 and err.strip().startswith("error:") and "Abort" not in err
    assert "cam01_keypoints2d.npz: empty or truncated npz file" in err


@pytest.mark.parametrize("value", ["1e308", "1e30", "inf", "-1e12"])
def test_bvh_with_an_absurd_frame_is_refused_naming_the_frame(tmp_path, value):
    with pytest.raises(InputError, match=r"broken\.bvh: .*frame 3 .*(from the origin|not a number|NaN or infinite)"):
        load_motion(corrupt_bvh(tmp_path, value))


def test_bvh_unchanged_still_loads(tmp_path):
    text = BVH.read_text()
    (motion,) = load_motion(corrupt_bvh(tmp_path, text.split("MOTION")[1].splitlines()[3].split()[0]))
    assert np.isfinite(motion.joints).all()


def test_train_on_the_1e308_bvh_is_one_line_and_writes_no_prior(run_cli, tmp_path):
    out = tmp_path / "prior.pt"
    code, _, err = run_cli("train", corrupt_bvh(tmp_path, "1e308"), "--out", out, "--iterations", "2")
    assert code == 2 and "broken.bvh: frame 3 channel 0 is 1e+308" in err and len(err.strip().splitlines()) == 1
    assert not out.exists()


CASES: list[Case] = []
case = registry(CASES)


@case("openpose-misnumbered-file")
def _(w: Path) -> Run:
    folder = openpose_copy(w, frames=4)
    (folder / "cam01.0003.json").rename(folder / "cam01.99999999.json")
    says = ("cam01_json: cam01.99999999.json (frame 99999999) comes 99999997 frames after frame 2",)
    return Run(["detect", folder, "--out", w / "out", *KEYPOINT_TIMING, "-q"], timeout=60, says=says)


@case("bvh-1e308-motion-info")
def _(w: Path) -> Run:
    return Run(["motion", "info", corrupt_bvh(w, "1e308")], says=("broken.bvh: frame 3 channel 0 is 1e+308",))


@case("truncated-video-detect")
def _(w: Path) -> Run:
    video = truncated_video(w)
    return Run(
        ["detect", video, "--out", w / "out", "--stride", "10", "-q", "--threads", "1"],
        "ok",
        lambda proc: None if "could be decoded" in proc.stderr else "no warning about the truncated video",
    )


@case("truncated-video-lift")
def _(w: Path) -> Run:
    video = truncated_video(w)
    out = w / "out"

    def check(proc) -> str | None:
        entry = summary(out)["inputs"][0]
        if "could be decoded" not in " ".join(entry.get("warnings", [])):
            return "summary.json does not say the video is truncated"
        return None if "could be decoded" in proc.stderr else "no warning on the console"

    return Run(
        ["lift", video, *FAST, "--stride", "10", "--formats", "npz", "--out", out, "--threads", "1"], "ok", check
    )


@case("json-image-size-0")
def _(w: Path) -> Run:
    args = ["detect", minimal_json(w, image_size=[0, 0]), "--out", w / "out", "-q"]
    return Run(args, says=("cam01.json: image size 0x0 (height x width) is not a real image size",))


@case("lift-json-image-size-0")
def _(w: Path) -> Run:
    args = ["lift", "--keypoints", minimal_json(w, image_size=[0, 0]), *FAST, "--out", w / "out"]
    return Run(args, says=("cam01.json: image size 0x0 (height x width) is not a real image size",))


@case("openpose-keypoints-far-outside-the-image")
def _(w: Path) -> Run:
    folder = openpose_copy(w)
    edit_json(folder / "cam01.0002.json", lambda c: c["people"][0]["pose_keypoints_2d"].__setitem__(1, -50000.0))
    says = ("cam01_json: frame 2: keypoint (0, 0) at (520.879, -50000) px lies far outside the 1088x1920 image",)
    return Run(["detect", folder, "--out", w / "out", *KEYPOINT_TIMING, "-q"], says=says)


@case("csv-zero-frame-times")
def _(w: Path) -> Run:
    path = rewrite_csv(real_csv(w), lambda rows: [r.__setitem__(2, "0.000000") for r in rows[1:]])
    args = ["lift", "--keypoints", path, "--image-size", "1920x1088", *FAST, "--out", w / "out"]
    return Run(args, says=("cam01_keypoints2d.csv", "frame times must be finite and increasing"))


@case("csv-short-row")
def _(w: Path) -> Run:
    path = rewrite_csv(real_csv(w), lambda rows: rows.__setitem__(5, rows[5][:4]))
    args = ["detect", path, "--image-size", "1920x1088", "--out", w / "out", "-q"]
    return Run(args, says=("cam01_keypoints2d.csv: row 6 has 4 values, not 7",))


@case("detect-fps-inf")
def _(w: Path) -> Run:
    args = ["detect", openpose_copy(w), "--fps", "inf", "--image-size", "1920x1088", "--out", w / "out", "-q"]
    return Run(args, says=("cam01_json: fps must be a number from 1 to 10000, got inf",))


@case("lift-fps-inf")
def _(w: Path) -> Run:
    return Run(
        [
            "lift",
            "--keypoints",
            openpose_copy(w),
            "--fps",
            "inf",
            "--image-size",
            "1920x1088",
            *FAST,
            "--out",
            w / "out",
        ],
        says=("cam01_json", "fps must be a number from 1 to 10000, got inf"),
    )


@case("lift-fps-1e-300")
def _(w: Path) -> Run:
    args = ["lift", "--keypoints", openpose_copy(w), "--fps", "1e-300", "--image-size", "1920x1088", *FAST]
    return Run([*args, "--out", w / "out"], says=("cam01_json", "fps must be a number from 1 to 10000, got 1e-300"))


@case("600-people-per-frame")
def _(w: Path) -> Run:
    folder = openpose_copy(w, frames=4)
    edit_json(folder / "cam01.0001.json", lambda c: c.__setitem__("people", c["people"][:1] * 600))
    says = ("cam01_json: frame 1 has 600 people; at most 100 per frame are supported",)
    return Run(["detect", folder, "--out", w / "out", *KEYPOINT_TIMING, "-q"], timeout=120, says=says)


@case("fractional-frame-numbers")
def _(w: Path) -> Run:
    path = minimal_json(w)
    edit_json(path, lambda c: c["frames"][1].__setitem__("frame", 1.5))
    return Run(
        ["detect", path, "--out", w / "out", "-q"], says=("cam01.json", "frame number 1.5 is not a whole number")
    )


@pytest.mark.audit
@pytest.mark.parametrize("audit_case", CASES, ids=[c.name for c in CASES])
def test_audit_case(audit_case: Case, tmp_path: Path) -> None:
    check_case(audit_case, tmp_path)
