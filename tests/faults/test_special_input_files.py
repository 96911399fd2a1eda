"""A FIFO (or another special file) given where lift reads an input file is refused before anything reads it: a
reader would block on it for ever, or read an endless writer whole. The audit case (marker ``audit``): ``bench --video`` of a FIFO
(:mod:`audit_support`)."""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest
from audit_support import Case, Run, check_case

from platypose.lifting.errors import InputError
from platypose.lifting.files.reads import check_readable_inputs

TAKE = Path(__file__).parents[2] / "data" / "video" / "pose2sim-balancing"


def test_a_fifo_itself_or_inside_a_folder_is_refused_by_name(tmp_path) -> None:
    fifo = tmp_path / "cam01.json"
    os.mkfifo(fifo)
    real = tmp_path / "real.csv"
    real.write_text("time,x,y,z\n")
    with pytest.raises(InputError, match=r"cam01\.json: is a FIFO \(named pipe\), a regular input file was expected"):
        check_readable_inputs([real, fifo])
    with pytest.raises(InputError, match=r"cam01\.json: is a FIFO"):
        check_readable_inputs([tmp_path])  # a keypoint folder holding it
    fifo.unlink()
    check_readable_inputs([real, tmp_path, tmp_path / "missing.npz"])  # regular files, folders: left to readers


def test_lift_refuses_a_fifo_root_trajectory_at_once(tmp_path) -> None:
    fifo = tmp_path / "root.csv"
    os.mkfifo(fifo)
    command = [sys.executable, "-m", "platypose", "lift", "--keypoints", str(TAKE / "openpose-body25b" / "cam01_json")]
    command += [
        "--cams",
        str(TAKE / "calib_pose2sim.toml"),
        "--root-trajectory",
        str(fifo),
        "--out",
        str(tmp_path / "out"),
        "-q",
    ]
    done = subprocess.run(command, capture_output=True, text=True, timeout=120)  # blocked for ever before
    assert done.returncode != 0
    assert f"{fifo}: is a FIFO (named pipe), a regular input file was expected" in done.stderr
    assert "Traceback" not in done.stderr and not (tmp_path / "out").exists()


def _bench_video_fifo(w: Path) -> Run:
    fifo = w / "clip.mp4"
    os.mkfifo(fifo)
    return Run(["bench", "--video", fifo, "-q"], says=("clip.mp4: is a FIFO (named pipe), not a video file to loop",))


@pytest.mark.audit
def test_bench_refuses_a_fifo_video_in_the_cli(tmp_path: Path) -> None:
    check_case(Case("bench-video-fifo", _bench_video_fifo), tmp_path)
