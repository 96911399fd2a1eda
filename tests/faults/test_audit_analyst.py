"""Audit, what a new analyst hit: whose picture each person gets, what a run says about its files and its
cameras, and the small things that read wrong; each ending in a clean error or handled well
(:mod:`audit_support`). Run with ``pytest -m audit``."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from audit_support import (
    TAKE,
    Case,
    Run,
    check_case,
    lift_args,
    one_camera_calibration,
    openpose_copy,
    platypose,
    registry,
    summary,
)
from export_helpers import read_entities

from platypose.exporters.npz import read_npz

pytestmark = pytest.mark.audit

CASES: list[Case] = []
case = registry(CASES)
WHO = re.compile(r"p(\d+): best seen by (\S+) in frame (\d+), image box (\d+),(\d+)-(\d+),(\d+) px")


def _own_pictures(npz: Path, recording: Path) -> str | None:
    """None when every person's picture in ``recording`` (its who/ texts) boxes their own joints in ``npz``, and no
    two people share a box; else what is wrong."""
    result = read_npz(npz)
    texts = [
        v["static:TextDocument:text"][0][0]
        for k, v in read_entities(recording).items()
        if re.fullmatch(r"/who/p\d+", k)
    ]
    boxes = {}
    for text in texts:
        track, camera, frame, *box = WHO.fullmatch(text).groups()
        c = [cam.name for cam in result.cameras].index(camera)
        joints = result.keypoints2d[c, list(result.track_ids).index(int(track)), int(frame)]
        joints = joints[joints[:, 2] > 0, :2]
        x1, y1, x2, y2 = map(float, box)
        if not ((joints >= [x1 - 1, y1 - 1]) & (joints <= [x2 + 1, y2 + 1])).all():
            return f"p{track}'s picture does not show p{track}: {text}"
        boxes[track] = tuple(box)
    if len(boxes) < 2 or len(set(boxes.values())) < len(boxes):
        return f"the people do not have pictures of their own: {texts}"
    return None


@case("every-person-gets-their-own-picture")
def _(w: Path) -> Run:
    done = platypose(lift_args(openpose_copy(w / "kp"), w / "res", "--formats", "npz"), 240)
    assert done is not None and done.returncode == 0, done and done.stderr
    npz = w / "res/cam01/cam01.npz"
    args = ["export", npz, "--formats", "rrd", "--out", w / "out", "--video", f"cam_01={TAKE / 'cam01.mp4'}"]
    return Run(args, "ok", lambda proc: _own_pictures(npz, w / "out/cam01.rrd"), timeout=240)


@case("one-camera-calibration-for-four-videos")
def _(w: Path) -> Run:
    calib = one_camera_calibration(w, "cam_01")
    take = w / "take"
    take.mkdir()
    for view in ("cam01", "cam02", "cam03", "cam04"):
        (take / f"{view}.mp4").symlink_to(TAKE / f"{view}.mp4")
    says = ("only_cam_01.json: the calibration has 1 camera (cam_01), you gave 4 videos", "cam04.mp4")
    return Run(["lift", take, "--cams", calib, "--out", w / "out", "-q"], says=says)


def _ik_warned(out: Path, stderr: str) -> str | None:
    """None when the lift's OpenSim IK warnings are in summary.json and on the console; else what is missing."""
    warnings = [w for entry in summary(out)["inputs"] for w in entry["warnings"] if "OpenSim IK" in w]
    if not warnings:
        return "summary.json lists no OpenSim IK warning"
    if f"warning: cam01: {warnings[0]}" not in stderr:
        return "the console does not say the OpenSim IK warning"
    return None


@case("lift-says-opensim-ik-warnings")
def _(w: Path) -> Run:
    keypoints = openpose_copy(w / "kp", frames=100)
    out = w / "out"
    timing = ["--fps", "20", "--image-size", "1920x1080", "--samples", "2", "--threads", "1"]
    args = ["lift", "--keypoints", keypoints, *timing, "-q", "--formats", "npz,mot", "--out", out]
    return Run(args, "ok", lambda proc: _ik_warned(out, proc.stderr), timeout=300)


@case("lift-writes-the-npz-whatever-the-formats")
def _(w: Path) -> Run:
    out = w / "out"
    args = [*lift_args(openpose_copy(w / "kp"), out, "--formats", "trc,angles")]
    return Run(args, "ok", lambda proc: None if (out / "cam01/cam01.npz").is_file() else "no npz written")


def _flag_lines(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if line.startswith("  ") and ": flagged: " in line]


@case("resume-repeats-the-flags-it-found")
def _(w: Path) -> Run:
    keypoints = w / "kp"
    keypoints.mkdir()
    for view, source in (("cam01", "cam02"), ("cam02", "cam01"), ("cam03", "cam03"), ("cam04", "cam04")):
        openpose_copy(w / view, source).rename(keypoints / f"{view}_json")
    args = [*lift_args(keypoints, w / "out", "--formats", "npz"), "--resume"]  # cam01 and cam02 swapped: flags

    def action() -> tuple[str, str]:
        first = platypose(args, 240)
        assert first is not None and first.returncode == 0 and _flag_lines(first.stderr), first and first.stderr
        again = platypose(args, 240)
        if again is None or again.returncode != 0 or "1 skipped" not in again.stdout:
            return "silent wrong", f"the resumed run did not skip the input: {again and again.stdout}"
        if _flag_lines(again.stderr) != _flag_lines(first.stderr):
            return "silent wrong", f"the resumed run says {_flag_lines(again.stderr)}, not {_flag_lines(first.stderr)}"
        return "handled well", "ok"

    return Run(action=action)


@pytest.mark.parametrize("audit_case", CASES, ids=[c.name for c in CASES])
def test_audit_case(audit_case: Case, tmp_path: Path) -> None:
    check_case(audit_case, tmp_path)
