"""Flags on real takes, end to end: good one-view videos print no warning lines and no flag but the body's own
(hinge jumps, joint angles: the one-view answer's, see docs/results.md); a person under the floor is flagged once, in
the same words in the console, log, summary.json, npz and recording."""

from __future__ import annotations

import json
from pathlib import Path

import pytest
from export_helpers import read_entities

TAKE = "video/pose2sim-balancing"


@pytest.mark.slow
def test_three_good_one_view_videos_print_no_warning_lines(run_cli, data_dir: Path, tmp_path: Path):
    videos = [data_dir / TAKE / f"cam0{i}.mp4" for i in (1, 2, 3)]
    args = ["lift", *videos, "--persons", "largest", "--samples", "10", "--formats", "npz", "--threads", "1"]
    code, out, err = run_cli(*args, "--out", tmp_path, "--quiet")
    assert code == 0, err
    assert [line for line in err.splitlines() if "warning" in line] == [], err
    # The one-view answer's forearms still swing faster than a body turns them (the rigid step, docs/results.md):
    # said as the body's flags, never as a floor, camera or reprojection problem. One view leaves the athlete's
    # depth open by about a metre: cam01's hypotheses lie 0.71-1.02 m from their median (seeds 0-2; 0.73-1.00 m
    # before one view's raised-support frames were steadied as unmeasured, 0.82-1.19 m with 20 hypotheses), on
    # the 1 m at which "spread" is flagged: a property of one view, said as a flag.
    body_flags = {"hinge jumps", "joint angles", "spread"}
    summary = json.loads((tmp_path / "summary.json").read_text())
    for entry in summary["inputs"]:
        assert entry["warnings"] == [] and entry["plausibility"][0]["one_view"]  # a property, not a warning
        assert set(entry["plausibility"][0]["flags"]) <= body_flags, entry["plausibility"]
        assert entry["floor"]["frame"].startswith("estimated world")
    assert out.count("look at it:") == 0 and out.count(": wrote ") == 3  # npz only: no recording to open


@pytest.mark.slow
def test_a_person_under_the_floor_is_flagged_once_in_the_same_words_everywhere(run_cli, data_dir, tmp_path):
    """Pose2Sim's take, four calibrated views: the woman behind the force plate stands 0.3 m under its z = 0."""
    from platypose.exporters.npz import read_npz

    take = data_dir / TAKE
    args = ["lift", "--keypoints", take / "openpose-body25b", "--cams", take / "calib_pose2sim.toml"]
    args += ["--samples", "10", "--formats", "npz,rrd", "--threads", "1", "--quiet", "--out", tmp_path]
    code, _, err = run_cli(*args)
    assert code == 0, err
    entry = json.loads((tmp_path / "summary.json").read_text())["inputs"][0]
    flagged = [r for r in entry["plausibility"] if r["flags"]]
    assert len(flagged) == 1 and "under floor" in flagged[0]["flags"], entry["plausibility"]
    person, said = flagged[0]["track_id"], flagged[0]["flag_text"]
    assert said.startswith("under floor (") and not any("flagged" in w for w in entry["warnings"])
    line = f"person {person}: flagged: {said}"
    assert err.count(line) == 1 and err.count("flagged") == 1  # once on the console
    folder = tmp_path / "openpose-body25b"
    assert (folder / "log.txt").read_text().count(line) == 1
    assert read_npz(folder / "openpose-body25b.npz").meta["plausibility"] == entry["plausibility"]
    entities = read_entities(folder / "openpose-body25b.rrd")
    assert f"flagged: {said}" in entities[f"/world/people/p{person}/plausibility"]["static:TextDocument:text"][0][0]
    assert f"p{person} (flagged: {', '.join(flagged[0]['flags'])})" in str(entities[f"/world/people/p{person}/label"])
