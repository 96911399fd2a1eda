"""Names and messages on the console and in files: characters that reverse, hide or break lines are never printed
raw, and file names that are not UTF-8 do not stop a log from being written."""

from __future__ import annotations

import json
import os
import shutil

import pytest
from audit_support import FAST, KEYPOINT_TIMING, OPENPOSE, platypose

from platypose.cli.terminal.safe_names import printable, safe_name
from platypose.lifting.job_log import JobLog

TRICKS = {
    "\u202e": "right-to-left override",
    "\u200b": "zero-width space",
    "\u2066": "left-to-right isolate",
    "\u009b": "C1 control sequence introducer",
    "\x85": "C1 next line",
    "\u2028": "line separator",
    "\u2029": "paragraph separator",
    "\udcff": "an undecodable byte of a file name",
}


@pytest.mark.parametrize("char", TRICKS, ids=TRICKS.values())
def test_printable_and_safe_names_hide_every_trick_character(char) -> None:
    assert printable(f"take{char}gnp.mp4") == "take?gnp.mp4"
    assert safe_name(f"take{char}1") == "take_1"
    safe_name(f"take{char}1").encode("utf-8")  # a file name in UTF-8
    assert printable("Überkopf ñ 走る 2.5 m, 30°") == "Überkopf ñ 走る 2.5 m, 30°"


def test_a_log_naming_an_undecodable_file_is_written(tmp_path) -> None:
    log = JobLog()
    log("input dayA/cam\udcff.mp4")
    log.write(tmp_path / "log.txt")
    assert "input dayA/cam\\udcff.mp4" in (tmp_path / "log.txt").read_text(encoding="utf-8")


@pytest.mark.audit
def test_a_lift_of_a_file_whose_name_is_not_utf8_writes_its_log_and_summary(tmp_path) -> None:
    source = os.fsdecode(bytes(tmp_path) + b"/cam01\xff_json")
    shutil.copytree(OPENPOSE / "cam01_json", source)
    out = tmp_path / "out"
    done = platypose(["lift", "--keypoints", source, *KEYPOINT_TIMING, *FAST, "--formats", "npz", "--out", out], 240)
    assert done is not None and done.returncode == 0, done and done.stderr
    assert "Traceback" not in done.stderr
    entry = json.loads((out / "summary.json").read_text())["inputs"][0]
    assert entry["status"] == "ok" and entry["name"] == "cam01_"
    assert "cam01\\udcff_json" in (out / "cam01_/log.txt").read_text(encoding="utf-8")


def test_a_newline_in_a_file_name_cannot_forge_an_error_line(run_cli, tmp_path) -> None:
    code, _, err = run_cli("calib", "check", str(tmp_path / "no\nerror: forged.toml"))
    assert code == 2 and len(err.strip().splitlines()) == 1 and "no?error: forged" in err, err
