"""Two lifts into one --out at once: the second writer of a folder refuses, and the folder holds
one run's files, as its lift.json says, never a mix."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import pytest
from audit_support import CALIB, FAST, KEYPOINT_TIMING, openpose_copy, platypose

from platypose.cli.runs.outputs import finished_outputs

pytestmark = pytest.mark.audit


def test_two_lifts_of_one_input_at_once_do_not_mix_their_files(tmp_path) -> None:
    keypoints = openpose_copy(tmp_path / "kp", frames=60)
    out = tmp_path / "out"
    runs = []
    for seed in ("1", "2"):
        args = ["lift", "--keypoints", keypoints, "--cams", CALIB, *KEYPOINT_TIMING, *FAST, "--seed", seed]
        command = [sys.executable, "-m", "platypose", *map(str, args), "--formats", "npz,csv", "--out", str(out)]
        environment = {**os.environ, "OMP_NUM_THREADS": "1"}
        runs.append(
            subprocess.Popen(command, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=environment)
        )
    results = [(run.wait(timeout=400), *run.communicate()) for run in runs]
    codes = sorted(code for code, _, _ in results)
    busy = f"another platypose run is writing {out / 'cam01'}/ now; wait for it to end, or lift into another --out"
    assert codes == [0, 2], results  # one ran, the other refused (both start together: their lifts overlap)
    refused = next(err for code, _, err in results if code == 2)
    assert busy in refused and "Traceback" not in refused
    folder = out / "cam01"
    outputs, why = finished_outputs(folder, ("npz", "csv"))
    assert outputs is not None, why  # every file as lift.json recorded it
    done = platypose(["export", folder / "cam01.npz", "--formats", "csv", "--out", tmp_path / "again", "-q"], 120)
    assert done is not None and done.returncode == 0
    assert (tmp_path / "again/cam01.csv").read_bytes() == (folder / "cam01.csv").read_bytes()  # one run's CSV and npz
    entry = json.loads((out / "summary.json").read_text())["inputs"][0]
    assert entry["status"] == "ok"  # the refusal ends at once; the run that wrote the folder ends last
