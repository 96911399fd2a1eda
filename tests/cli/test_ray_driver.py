"""``-q`` with ``--executor ray``: a Ray cluster started by the lift prints no Ray warnings (issue 30 item 13:
Ray's token-authentication warning came through ``-q``); the lift's own flags still print."""

from __future__ import annotations

import os
import subprocess
import sys


def test_a_quiet_ray_lift_prints_no_ray_warning(batch_folder, prior_file, tmp_path) -> None:
    env = {k: v for k, v in os.environ.items() if not k.startswith("RAY_")}  # Ray's own defaults, no token set
    args = ["lift", str(batch_folder / "good.mp4"), "--prior", str(prior_file), "--samples", "2", "--threads", "1"]
    args += ["--formats", "npz", "--executor", "ray", "--out", str(tmp_path / "out"), "-q"]
    done = subprocess.run([sys.executable, "-m", "platypose", *args], capture_output=True, text=True, env=env)
    assert done.returncode == 0, done.stderr
    assert "Token authentication" not in done.stderr and "WARNING" not in done.stderr, done.stderr
