"""``lift --executor ray --collect``: what the driver does with a job's collected files (``lift_ray.write_collected``),
on the files of real lifts of the balancing take's cam01 keypoints: an earlier run's outputs that the collected set
does not hold are removed, as a local run removes them, and another run holding the job's folder is waited for
with a line saying so."""

from __future__ import annotations

import json
import shutil
import threading
import time
from pathlib import Path

from platypose.cli.runs.job import JOB_LOCK
from platypose.cli.runs.locks import exclusive_lock
from platypose.cli.runs.ray import write_collected

K = ["--fps", "20", "--image-size", "1920x1080", "--samples", "2", "--threads", "1", "-q"]


def lift(run_cli, data_dir, tmp_path: Path, out: Path, formats: str) -> dict:
    """A real lift of cam01's first 20 OpenPose frames into ``out``; its summary entry."""
    keypoints = tmp_path / "kp/cam01_json"
    if not keypoints.exists():
        keypoints.mkdir(parents=True)
        for path in sorted((data_dir / "video/pose2sim-balancing/openpose-body25b/cam01_json").glob("*.json"))[:20]:
            shutil.copy(path, keypoints / path.name)
    code, _, err = run_cli("lift", "--keypoints", keypoints, *K, "--formats", formats, "--out", out)
    assert code == 0, err
    (entry,) = json.loads((out / "summary.json").read_text())["inputs"]
    return entry


def collected(out: Path, entry: dict) -> dict[str, bytes]:
    """The files a worker sends back for ``entry``'s job, as ``lift_on_worker`` gathers them."""
    folder = out / entry["name"]
    return {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def test_collect_removes_an_earlier_runs_outputs(run_cli, data_dir, tmp_path):
    """An earlier run wrote npz, CSV and angles; the collected run wrote only the npz: the CSV and angles go, the
    log says which, and lift.json lists exactly the files there."""
    folder = tmp_path / "out/cam01"
    lift(run_cli, data_dir, tmp_path, tmp_path / "out", "npz,csv,angles")
    assert (folder / "cam01.csv").is_file() and (folder / "cam01_angles.csv").is_file()
    entry = lift(run_cli, data_dir, tmp_path, tmp_path / "scratch", "npz")
    entry = write_collected(folder, entry, collected(tmp_path / "scratch", entry))
    manifest = json.loads((folder / "lift.json").read_text())
    outputs = sorted(p.name for p in folder.iterdir() if p.name.startswith("cam01"))
    assert outputs == manifest["outputs"] == ["cam01.npz"], outputs
    assert (
        "removed output(s) of an earlier run that this run did not write: cam01.csv, cam01_angles.csv"
        in (folder / "log.txt").read_text()
    )


def test_collect_says_when_it_waits_for_another_run(run_cli, data_dir, tmp_path):
    """With the job's lock held by another run, the driver says it waits, writes nothing meanwhile, and writes
    the files once the lock is released."""
    entry = lift(run_cli, data_dir, tmp_path, tmp_path / "scratch", "npz")
    files = collected(tmp_path / "scratch", entry)
    folder = tmp_path / "out/cam01"
    folder.mkdir(parents=True)
    said: list[str] = []
    with exclusive_lock(folder / JOB_LOCK):
        writer = threading.Thread(target=write_collected, args=(folder, entry, files, said.append))
        writer.start()
        time.sleep(1.0)
        assert said == [f"cam01: another platypose run is writing {folder}/ now; waiting for it to end"]
        assert not (folder / "cam01.npz").exists()
    writer.join(30)
    assert (folder / "cam01.npz").is_file() and (folder / "lift.json").is_file()
