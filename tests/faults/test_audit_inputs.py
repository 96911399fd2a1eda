"""Audit, bad input files: crafted pickles, damaged keypoints, BVH, calibration, video and CSV against the
real CLI, each ending in a clean error or handled well (:mod:`audit_support`). Run with ``pytest -m audit``."""

from __future__ import annotations

from pathlib import Path

import pytest
from audit_support import (
    FAST,
    KEYPOINT_TIMING,
    REPO,
    WALK,
    Case,
    Run,
    check_case,
    corrupt_bvh,
    edit_json,
    lift_args,
    malicious_h36m,
    minimal_json,
    one_camera_calibration,
    openpose_copy,
    real_csv,
    registry,
    rewrite_csv,
    summary,
    swapped_calibration,
    truncated_video,
)

pytestmark = pytest.mark.audit

CASES: list[Case] = []
case = registry(CASES)


@case("h36m-malicious-motion-info")
def _(w: Path) -> Run:
    data, marker = malicious_h36m(w)
    return Run(
        ["motion", "info", data],
        marker=marker,
        says=("data_3d_h36m.npz: 'positions_3d' holds more than bounded numpy arrays", "refused to load io.open"),
    )


@case("h36m-malicious-train-folder-scan")
def _(w: Path) -> Run:
    data, marker = malicious_h36m(w)
    args = ["train", data.parent, "--out", w / "p.pt", "--iterations", "1"]
    return Run(
        args,
        marker=marker,
        says=("data_3d_h36m.npz: 'positions_3d' holds more than bounded numpy arrays", "refused to load io.open"),
    )


@case("h36m-malicious-eval")
def _(w: Path) -> Run:
    data, marker = malicious_h36m(w)
    return Run(
        ["eval", data, "--frames", "1", "--samples", "2"],
        marker=marker,
        says=("data_3d_h36m.npz: 'positions_3d' holds more than bounded numpy arrays", "refused to load io.open"),
    )


@case("openpose-misnumbered-file")
def _(w: Path) -> Run:
    folder = openpose_copy(w, frames=4)
    (folder / "cam01.0003.json").rename(folder / "cam01.99999999.json")
    says = ("cam01_json: cam01.99999999.json (frame 99999999) comes 99999997 frames after frame 2",)
    return Run(["detect", folder, "--out", w / "out", *KEYPOINT_TIMING, "-q"], timeout=60, says=says)


@case("one-camera-calibration-for-another-view")
def _(w: Path) -> Run:
    calib = one_camera_calibration(w, "cam_01")
    keypoints = openpose_copy(w / "kp", "cam02")
    args = ["lift", "--keypoints", keypoints, "--cams", calib, *KEYPOINT_TIMING, *FAST, "--out", w / "out"]
    return Run(args, says=("cam02_json", "calibration mismatch with", "only_cam_01.json"))


@case("bvh-1e308-motion-info")
def _(w: Path) -> Run:
    return Run(["motion", "info", corrupt_bvh(w, "1e308")], says=("broken.bvh: frame 3 channel 0 is 1e+308",))


@case("bvh-1e308-train")
def _(w: Path) -> Run:
    out = w / "p.pt"
    return Run(
        ["train", corrupt_bvh(w, "1e308"), "--out", out, "--iterations", "2"],
        check=lambda proc: "a prior was written" if out.exists() else None,
        says=("broken.bvh: frame 3 channel 0 is 1e+308",),
    )


@case("prior-with-nan-weights-prior-info")
def _(w: Path) -> Run:
    import torch

    payload = torch.load(REPO / "lifting/prior/weights/default.pt", weights_only=True)
    first = next(iter(payload["state_dict"]))
    payload["state_dict"][first] = payload["state_dict"][first] * float("nan")
    torch.save(payload, w / "nan.pt")
    return Run(["prior-info", w / "nan.pt"], says=("nan.pt: prior weights 'input.weight' hold NaN or infinite values",))


@case("swapped-calibrations")
def _(w: Path) -> Run:
    calib = swapped_calibration(w)
    kp = w / "kp"
    for view in ("cam01", "cam02"):
        openpose_copy(kp, view, frames=20)
    out = w / "out"

    def check(proc) -> str | None:
        entries = summary(out)["inputs"]
        warned = any(
            "cam_01" in " ".join(e.get("warnings", [])) or "cam_02" in " ".join(e.get("warnings", [])) for e in entries
        )
        if not warned:
            return "no warning naming the swapped view in summary.json"
        if "warning" not in proc.stderr:
            return "no warning on the console"
        return None

    args = ["lift", "--keypoints", kp, "--cams", calib, *KEYPOINT_TIMING, *FAST[:-1], "--out", out, "--formats", "npz"]
    return Run(args, "ok", check)


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


@case("openpose-keypoint-1e30")
def _(w: Path) -> Run:
    folder = openpose_copy(w)
    edit_json(folder / "cam01.0002.json", lambda c: c["people"][0]["pose_keypoints_2d"].__setitem__(0, 1e30))
    return Run(
        lift_args(folder, w / "out"), says=("cam01_json", "frame 2: keypoint (0, 0) at (1e+30,", "lies far outside")
    )


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


@case("lift-seed-1e23")
def _(w: Path) -> Run:
    args = [*lift_args(openpose_copy(w), w / "out"), "--seed", str(10**23)]
    return Run(args, says=("--seed must be in 0..2**63-1, got 100000000000000000000000",))


@case("lift-samples-1e9")
def _(w: Path) -> Run:
    args = [*lift_args(openpose_copy(w), w / "out"), "--samples", str(10**9)]
    return Run(args, says=("--samples must be at most 5000, got 1000000000",))


@case("lift-long-file-name")
def _(w: Path) -> Run:
    folder = openpose_copy(w)
    long = folder.rename(w / ("x" * 240 + "_json"))
    args = ["lift", "--keypoints", long, *KEYPOINT_TIMING, *FAST, "--out", w / "out", "--formats", "npz,csv,bvh"]
    return Run(args, "ok")  # no --cams: a view named x...x matches no camera of the Pose2Sim calibration


@case("zero-byte-npz-detect")
def _(w: Path) -> Run:
    (w / "cam01_keypoints2d.npz").write_bytes(b"")
    args = ["detect", w / "cam01_keypoints2d.npz", "--out", w / "out", "-q"]
    return Run(args, says=("cam01_keypoints2d.npz: empty or truncated npz file",))


@case("zero-byte-npz-info")
def _(w: Path) -> Run:
    (w / "clip.npz").write_bytes(b"")
    return Run(["info", w / "clip.npz"], says=("clip.npz: empty or truncated npz file",))


for _options, _says in (
    (["--max-frames", "0"], "train: max_frames must be at least 1, got 0"),
    (["--fps", "0"], "train: fps must be a positive number, got 0.0"),
    (["--width", "10", "--heads", "3"], "train: width 10 must be even and a multiple of heads (3)"),
    (["--learning-rate", "nan"], "--learning-rate must be a finite number, got nan"),
):

    def _build(w: Path, options=_options, says=_says) -> Run:
        return Run(["train", WALK, "--out", w / "p.pt", "--iterations", "2", *options], says=(says,))

    CASES.append(Case("train" + "".join(o if o.startswith("--") else f"-{o}" for o in _options), _build))


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


@case("lift-help-keeps-bracketed-defaults")
def _(w: Path) -> Run:
    def check(proc) -> str | None:
        shown = " ".join(proc.stdout.split())
        missing = [b for b in ("[default: 50]", "[default: l2]", "[default: out]") if b not in shown]
        if "[default: (" in shown:  # a settings option's default shown as a description (issue 52, item 12)
            return "--help shows a default in parentheses"
        return f"--help lost {missing}" if missing else None

    return Run(["lift", "--help-all"], "ok", check)  # every option: --help shows the common ones


@pytest.mark.parametrize("audit_case", CASES, ids=[c.name for c in CASES])
def test_audit_case(audit_case: Case, tmp_path: Path) -> None:
    check_case(audit_case, tmp_path)
