"""--resume skips only what is finished and unchanged: an output set half switched by a killed run, a changed
output, a leftover staging folder, another runtime, or keypoints copied with an old time are redone (the audit cases, marker ``audit``, through the real CLI: :mod:`audit_watch`)."""

from __future__ import annotations

import json
import os
import shutil
from pathlib import Path

import pytest
from audit_support import KEYPOINT_TIMING
from audit_watch import LIFT, TAKE, check


def test_a_half_switched_output_set_is_not_taken_as_finished(run_cli, monkeypatch, tmp_path, batch_folder, prior_file):

    args = ("lift", str(batch_folder / "good.mp4"), "--prior", prior_file, "--out", str(tmp_path), "--quiet")
    old = (*args, "--samples", "2", "--formats", "npz,bvh")
    assert run_cli(*old)[0] == 0
    folder = tmp_path / "good"
    real_replace, moved = os.replace, []

    def killed_after_one(src, dst):  # the re-run dies after moving its first output into place
        if ".partial" in str(src) and ".partial" not in str(dst):
            if moved:
                raise KeyboardInterrupt
            moved.append(dst)
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", killed_after_one)
    code, _, _ = run_cli(*args, "--samples", "3", "--formats", "npz,bvh")
    monkeypatch.setattr(os, "replace", real_replace)
    assert code == 130 and len(moved) == 1
    (tmp_path / ".good.999999999.x.partial").mkdir()  # what a SIGKILL leaves
    code, out, err = run_cli(*old, "--resume")
    assert code == 0 and "1 ok, 0 failed, 0 skipped" in out, out + err
    assert not list(tmp_path.glob(".good.*.partial"))
    code, out, _ = run_cli(*old, "--resume")
    assert code == 0 and "0 ok, 0 failed, 1 skipped" in out
    bvh = folder / "good_p0.bvh"
    text = bvh.read_text()
    bvh.write_text(text[:-2] + ("1" if text[-2] != "1" else "2") + text[-1])  # same size, other content
    code, out, _ = run_cli(*old, "--resume")
    assert code == 0 and "1 ok, 0 failed, 0 skipped" in out, out
    (tmp_path / ".good.999999999.y.partial").mkdir()
    code, out, _ = run_cli(*old, "--resume")
    assert "1 skipped" in out and not list(tmp_path.glob(".good.*.partial"))  # skipped, and the leftover removed


def test_resume_fingerprint_sees_runtime_and_keypoints_copied_with_old_times(data_dir, tmp_path) -> None:
    from dataclasses import replace

    from platypose.cli.runs.fingerprint import fingerprint
    from platypose.cli.runs.jobs import keypoints_job
    from platypose.cli.runs.settings import RunSettings
    from platypose.lifting.settings import PriorSettings

    folder = tmp_path / "cam01_json"
    shutil.copytree(data_dir / "video/pose2sim-balancing/openpose-body25b/cam01_json", folder)
    job = keypoints_job(folder, [], ())
    settings = RunSettings(out=tmp_path / "out")
    before = fingerprint(job, settings)
    assert fingerprint(job, settings) == before
    assert fingerprint(job, replace(settings, prior=PriorSettings(runtime="bfloat16"))) != before
    files = sorted(folder.iterdir())
    shutil.copy2(files[-1], files[len(files) // 2])  # cp -p: other content, an older time, same count
    assert fingerprint(job, settings) != before


def _skipped(out: Path) -> int:
    return json.loads((out / "summary.json").read_text())["counts"]["skipped"]


@pytest.mark.audit
def test_resume_redoes_what_changed(batch_folder, tmp_path: Path) -> None:
    out = tmp_path / "out"
    base = ["lift", batch_folder / "good.mp4", "--out", out, "--formats", "npz,bvh", *LIFT]
    check(tmp_path / "first", base, "ok", out=out)
    bvh = out / "good/good_p0.bvh"
    text = bvh.read_text()
    bvh.write_text(text[:-2] + ("1" if text[-2] != "1" else "2") + text[-1])
    (out / ".good.999999999.x.partial").mkdir()
    check(tmp_path / "changed-output", [*base, "--resume"], "ok", out=out)
    assert not _skipped(out), "a changed output was skipped"
    assert not list(out.glob(".good.*.partial")), "a stale staging folder was left"
    check(tmp_path / "runtime", [*base, "--resume", "--runtime", "float32"], "ok", out=out)
    assert not _skipped(out), "a run with another runtime was skipped"


@pytest.mark.audit
def test_resume_sees_keypoints_copied_with_an_old_time(tmp_path: Path) -> None:
    views = tmp_path / "kp/cam01_json"
    shutil.copytree(TAKE / "openpose-body25b/cam01_json", views)
    out = tmp_path / "out"
    base = ["lift", "--keypoints", views, *KEYPOINT_TIMING, "--out", out, "--formats", "npz", *LIFT]
    check(tmp_path / "first", base, "ok", out=out)
    files = sorted(views.iterdir())
    shutil.copy2(files[-1], files[len(files) // 2])
    check(tmp_path / "again", [*base, "--resume"], "ok", out=out)
    assert not _skipped(out), "keypoints copied with an old time were skipped"
