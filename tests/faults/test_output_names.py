"""Job names from input file names stay inside --out: dots, hidden names, names of our own files, newlines and
very long names become safe folder and file names, and a lift of such inputs writes nothing beside OUT."""

from __future__ import annotations

import shutil

from platypose.cli.runs.jobs import discover_jobs, keypoints_job
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
