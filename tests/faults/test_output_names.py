"""Job names and output folders: names from input file names stay inside --out (dots, hidden names, names of our
own files, newlines and very long names become safe folder and file names, and a lift of such inputs writes nothing
beside OUT); one output folder per input (names that collide in a batch, a folder an earlier run wrote for another
input). The audit cases (marker ``audit``) run the real CLI (:mod:`audit_watch`), and lift a view named by 240
characters into every format (:mod:`audit_support`)."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pytest
from audit_support import (
    CALIB,
    FAST,
    KEYPOINT_TIMING,
    Case,
    Run,
    check_case,
    minimal_json,
    openpose_copy,
    platypose,
    registry,
)
from audit_watch import LIFT, check

from platypose.cli.runs.jobs import Job, View, discover_jobs, keypoints_job
from platypose.cli.terminal.safe_names import safe_name


def _listing(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_job_names_are_safe_file_names(data_dir, tmp_path) -> None:
    video = data_dir / "video/pose2sim-balancing/cam01.mp4"
    for name in ("...mp4", "..mp4", ".hidden.mp4", "summary.json.mp4", "a\nerror: forged.mp4"):
        shutil.copy(video, tmp_path / name)
    names = [job.name for job in discover_jobs([tmp_path])]
    assert sorted(names) == sorted(["__", "_", "_hidden", "summary.json_take", "a_error_ forged"]), names
    assert all(safe_name(n) == n for n in names)
    shutil.copy(data_dir / "video/sports2d-demo/movenet-detections.npz", tmp_path / "..npz")
    assert keypoints_job(tmp_path / "..npz", [], ()).name == "_"
    assert safe_name("x" * 300) == "x" * 120 and safe_name("") == "take" and safe_name("a/b\\c") == "a_b_c"


def test_lift_of_dot_dot_stem_writes_only_inside_out(run_cli, tmp_path, prior_file, batch_folder) -> None:
    inputs = tmp_path / "in"
    inputs.mkdir()
    shutil.copy(batch_folder / "good.mp4", inputs / "...mp4")
    shutil.copy(batch_folder / "good.mp4", inputs / "..mp4")
    parent = tmp_path / "parent"
    out = parent / "out"
    parent.mkdir()
    code, _, err = run_cli(
        "lift", str(inputs), "--prior", prior_file, "--out", str(out), "--samples", "2", "--formats", "npz",
        "--quiet", "--threads", "1",
    )  # fmt: skip
    assert code == 0, err
    assert _listing(parent) == sorted(["out"] + [f"out/{p}" for p in _listing(out)])  # nothing beside OUT
    assert not [p for p in out.iterdir() if p.name.startswith(".") and p.name != ".summary.lock"]
    assert (out / "__" / "__.npz").is_file() and (out / "_" / "_.npz").is_file()


def _video(path: Path) -> Path:
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_bytes(b"")  # a name is all naming needs
    return path


def test_a_renamed_input_does_not_take_the_name_of_another_input(tmp_path) -> None:
    videos = [_video(tmp_path / "x/a.mp4"), _video(tmp_path / "y/a.mp4"), _video(tmp_path / "z/a-2.mp4")]
    jobs = discover_jobs(videos)
    names = {job.input: job.name for job in jobs}
    assert names[str(videos[2])] == "a-2"  # keeps its own name
    assert names[str(videos[0])] == "a" and names[str(videos[1])] == "a-3"
    from platypose.cli.terminal.safe_names import distinct_names

    assert distinct_names(["Take", "take", "take-2"]) == ["Take", "take-3", "take-2"]  # case-blind file systems


def _job(source: Path) -> Job:
    return Job("take1", str(source), (View("take1", source, source),))


def _record(folder: Path, job: Job, **fields) -> None:
    from platypose.cli.runs.jobs import job_sources

    folder.mkdir(parents=True)
    record = {"input": job.input, "sources": job_sources(job), "outputs": [], "formats": ["npz"], **fields}
    (folder / "lift.json").write_text(json.dumps(record))


def test_a_folder_written_for_another_input_is_left_to_it(tmp_path) -> None:
    from platypose.cli.runs.folders import claim_folders

    out = tmp_path / "out"
    day_a, day_b = _job(_video(tmp_path / "dayA/take1.mp4")), _job(_video(tmp_path / "dayB/take1.mp4"))
    _record(out / "take1", day_a)
    assert [j.name for j in claim_folders([day_b], out)] == ["take1-2"]  # not dayA's folder
    assert [j.name for j in claim_folders([day_a], out)] == ["take1"]  # its own: --resume finds it
    _record(out / "take1-2", day_b)
    assert [j.name for j in claim_folders([day_b], out)] == ["take1-2"]
    day_c = _job(_video(tmp_path / "dayC/take1.mp4"))
    assert [j.name for j in claim_folders([day_c, day_b], out)] == ["take1-3", "take1-2"]


def test_a_folder_of_an_older_version_is_compared_by_the_input_as_given(tmp_path) -> None:
    from platypose.cli.runs.folders import claim_folders

    out = tmp_path / "out"
    day_a, day_b = _job(_video(tmp_path / "dayA/take1.mp4")), _job(_video(tmp_path / "dayB/take1.mp4"))
    (out / "take1").mkdir(parents=True)
    (out / "take1/failed.json").write_text(json.dumps({"input": day_a.input, "error": "x", "fingerprint": "f"}))
    assert claim_folders([day_b], out)[0].name == "take1-2"
    assert claim_folders([day_a], out)[0].name == "take1"


@pytest.mark.audit
def test_resume_of_a_second_input_of_one_name_keeps_the_first_ones_results(tmp_path) -> None:
    out = tmp_path / "out"
    day_a, day_b = tmp_path / "dayA", tmp_path / "dayB"
    day_a.mkdir()
    day_b.mkdir()
    first, second = minimal_json(day_a), minimal_json(day_b)
    common = ["--cams", CALIB, *KEYPOINT_TIMING, *FAST, "--formats", "npz", "--out", out]
    done = platypose(["lift", "--keypoints", first, *common], 240)
    assert done is not None and done.returncode == 0, done and done.stderr
    manifest = (out / "cam01/lift.json").read_text()
    npz = (out / "cam01/cam01.npz").read_bytes()
    done = platypose(["lift", "--keypoints", second, *common, "--resume", "--seed", "3"], 240)
    assert done is not None and done.returncode == 0, done and done.stderr
    assert (out / "cam01/lift.json").read_text() == manifest and (out / "cam01/cam01.npz").read_bytes() == npz
    assert json.loads((out / "cam01-2/lift.json").read_text())["sources"] == [str(second.resolve())]
    assert f"{out / 'cam01'}/ holds another input's results; writing {out / 'cam01-2'}/" in done.stderr
    entries = {e["name"]: e for e in json.loads((out / "summary.json").read_text())["inputs"]}
    assert entries["cam01"]["input"] == str(first) and entries["cam01-2"]["input"] == str(second)


@pytest.mark.audit
def test_job_names_stay_inside_out(batch_folder, tmp_path: Path) -> None:
    names = tmp_path / "in"
    names.mkdir()
    for n in ("...mp4", "..mp4", ".hidden.mp4", "summary.json.mp4", "a\nerror: forged.mp4", "x" * 240 + ".mp4"):
        shutil.copy(batch_folder / "good.mp4", names / n)
    out = tmp_path / "out"
    check(tmp_path, ["lift", names, "--out", out, "--formats", "npz,bvh", *LIFT], "ok", out=out)


CASES: list[Case] = []
case = registry(CASES)


@case("lift-long-file-name")
def _(w: Path) -> Run:
    folder = openpose_copy(w)
    long = folder.rename(w / ("x" * 240 + "_json"))
    args = ["lift", "--keypoints", long, *KEYPOINT_TIMING, *FAST, "--out", w / "out", "--formats", "npz,csv,bvh"]
    return Run(args, "ok")  # no --cams: a view named x...x matches no camera of the Pose2Sim calibration


@pytest.mark.audit
@pytest.mark.parametrize("audit_case", CASES, ids=[c.name for c in CASES])
def test_audit_case(audit_case: Case, tmp_path: Path) -> None:
    check_case(audit_case, tmp_path)
