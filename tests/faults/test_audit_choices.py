"""Audit cases (marker ``audit``, run with ``pytest -m audit``): what a user types for who to lift, sync, a Ray
address and sampler numbers, and what a calibration, a prior or a motion file claims, against the real CLI; each
must end in a clean error (checked for its words) or be handled well (:mod:`audit_support`)."""

from __future__ import annotations

import json
import os
from pathlib import Path

import pytest
from audit_support import (
    CALIB,
    FAST,
    Case,
    Run,
    check_case,
    lift_args,
    openpose_copy,
    platypose,
    registry,
)

pytestmark = pytest.mark.audit

CASES: list[Case] = []
case = registry(CASES)


@case("persons-superscript")
def _(w: Path) -> Run:
    return Run(lift_args(openpose_copy(w), w / "out", "--persons", "²"), says=("--persons", "got '²'"))


@case("ray-port-superscript")
def _(w: Path) -> Run:
    args = lift_args(openpose_copy(w), w / "out", "--executor", "ray", "--ray-address", "127.0.0.1:²")
    return Run(args, says=("--ray-address 127.0.0.1:²: not an address",))


@case("persons-point-outside-the-image")
def _(w: Path) -> Run:
    args = lift_args(openpose_copy(w), w / "out", "--persons", "@-50000,-50000")
    return Run(args, says=("@-50000,-50000: the point is outside the first view's image (1088x1920 pixels",))


@case("persons-plain-number-is-ambiguous")
def _(w: Path) -> Run:
    args = lift_args(openpose_copy(w), w / "out", "--persons", "1")
    return Run(args, says=("a plain number is ambiguous; write largest:1", "id:1"))


@case("temperature-just-over-its-bound-says-both-as-they-are")
def _(w: Path) -> Run:
    args = lift_args(openpose_copy(w), w / "out", "--temperature", "1000000.5")
    return Run(args, says=("--temperature", "must be between -1,000,000 and 1,000,000, got 1000000.5"))


@case("split-with-a-max-gap-of-1e308")
def _(w: Path) -> Run:
    args = lift_args(openpose_copy(w), w / "out", "--max-gap", "1e308", "--split-seconds", "2", "--jobs", "2")
    return Run(args, says=("--max-gap", "from 0 to 86400 (a day), got 1e+308"))


@case("bench-video-fifo")
def _(w: Path) -> Run:
    fifo = w / "clip.mp4"
    os.mkfifo(fifo)
    return Run(["bench", "--video", fifo, "-q"], says=("clip.mp4: is a FIFO (named pipe), not a video file to loop",))


@case("energy-scale-1e308")
def _(w: Path) -> Run:
    args = lift_args(openpose_copy(w), w / "out", "--energy-scale", "1e308")
    return Run(args, says=("energy-scale", "must be between -1,000,000 and 1,000,000, got 1e+308"))


@case("calibration-time-offset-1e308")
def _(w: Path) -> Run:
    full = w / "calib.json"
    done = platypose(["calib", "convert", CALIB, "--out", full], 60)
    assert done is not None and done.returncode == 0, done and done.stderr
    content = json.loads(full.read_text())
    content["cameras"][0]["time_offset_s"] = 1e308
    full.write_text(json.dumps(content))
    return Run(["calib", "check", full], says=("time_offset_s 1e+308 is out of range",))


@case("root-trajectory-npz-claiming-180-gib")
def _(w: Path) -> Run:
    import io
    import zipfile

    import numpy as np

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


@case("asf-cycle")
def _(w: Path) -> Run:
    asf = Path(__file__).resolve().parents[2] / "data/motion/cmu-asf-amc/test.asf"
    (w / "test.asf").write_text(asf.read_text().replace("    ltibia lfoot\n", "    ltibia lfoot lfemur\n"))
    (w / "test.amc").write_bytes(asf.with_suffix(".amc").read_bytes())
    return Run(["motion", "info", w / "test.amc"], says=("hierarchy lists bone 'lfemur' twice",), timeout=60)


@case("calibration-of-another-size-before-detection")
def _(w: Path) -> Run:
    full = w / "calib.json"
    done = platypose(["calib", "convert", CALIB, "--out", full], 60)
    assert done is not None and done.returncode == 0, done and done.stderr
    content = json.loads(full.read_text())
    for camera in content["cameras"]:
        camera["size"] = [720, 1280]
    full.write_text(json.dumps(content))
    video = Path(CALIB).parent / "cam01.mp4"
    args = ["lift", video, "--cams", full, *FAST, "--out", w / "out"]
    return Run(args, says=("calibration mismatch: calibration says 1280x720 px for camera cam_01",), timeout=60)


@pytest.mark.parametrize("audit_case", CASES, ids=[c.name for c in CASES])
def test_audit_case(audit_case: Case, tmp_path: Path) -> None:
    check_case(audit_case, tmp_path)
