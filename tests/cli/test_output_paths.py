"""Outputs that cannot be written (a file in the way, a folder given for a file, a read-only
folder, a name too long) are one-line errors naming the path, before any work, in detect, export, calib
convert and train; nothing is left behind."""

from __future__ import annotations

import os
import subprocess
import uuid

import pytest

from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import check_writable

POSE2SIM = "video/pose2sim-balancing"


def one_line_error(code: int, err: str, *needles: str) -> None:
    lines = [line for line in err.strip().splitlines() if line.strip()]
    assert code == 2 and len(lines) == 1 and lines[0].startswith("error:"), err
    for needle in needles:
        assert needle in lines[0], err


@pytest.fixture
def read_only_folder(tmp_path):
    """A folder this process cannot write into: a read-only tmpfs as root (where mounting works), else chmod 500."""
    folder = tmp_path / f"ro-{uuid.uuid4().hex[:6]}"
    folder.mkdir()
    if os.geteuid() != 0:
        folder.chmod(0o500)
        yield folder
        folder.chmod(0o700)
        return
    done = subprocess.run(["mount", "-t", "tmpfs", "-o", "ro,size=64k", "tmpfs", str(folder)], capture_output=True)
    if done.returncode != 0:
        pytest.skip("root without mount rights: no read-only folder to test with")
    yield folder
    subprocess.run(["umount", "-l", str(folder)], check=False)


def test_check_writable_kinds(tmp_path, read_only_folder):
    (tmp_path / "file").write_text("x")
    with pytest.raises(InputError, match=r"file is a file, not a folder"):
        check_writable(tmp_path / "file" / "sub" / "out.json")
    with pytest.raises(InputError, match="is a folder, an output file name was expected"):
        check_writable(tmp_path)
    with pytest.raises(InputError, match="is a file, an output folder was expected"):
        check_writable(tmp_path / "file", folder=True)
    with pytest.raises(InputError, match="file name too long"):
        check_writable(tmp_path / ("n" * 250 + ".json"))
    with pytest.raises(InputError, match="cannot write there"):
        check_writable(read_only_folder / "out.json")
    assert check_writable(tmp_path / "new" / "out.json") == tmp_path / "new" / "out.json"
    assert [p.name for p in (tmp_path / "new").iterdir()] == []  # the probe file is gone


def test_calib_convert_out_paths(run_cli, data_dir, tmp_path, read_only_folder):
    calib = data_dir / POSE2SIM / "calib_pose2sim.toml"
    (tmp_path / "file").write_text("x")
    for out, needle in [
        (tmp_path, "is a folder"),
        (tmp_path / "file" / "calib.json", "is a file, not a folder"),
        (read_only_folder / "calib.json", "cannot write there"),
        (tmp_path / ("c" * 300 + ".json"), "too long"),
    ]:
        code, _, err = run_cli("calib", "convert", calib, "--out", out)
        one_line_error(code, err, needle)
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.startswith("ro-")) == ["file"]


def test_detect_out_paths(run_cli, data_dir, tmp_path, read_only_folder):
    source = data_dir / POSE2SIM / "openpose-body25b/cam01_json"
    (tmp_path / "file").write_text("x")
    for out, needle in [(tmp_path / "file", "is a file"), (read_only_folder, "cannot write there")]:
        code, _, err = run_cli("detect", source, "--out", out, "-q")
        one_line_error(code, err, needle)


def test_export_out_paths(run_cli, data_dir, tmp_path, read_only_folder):
    from export_helpers import two_person_result

    from platypose.exporters.npz import write_npz

    npz = write_npz(two_person_result(data_dir), tmp_path / "clip.npz")
    (tmp_path / "file").write_text("x")
    for out, needle in [(tmp_path / "file", "is a file"), (read_only_folder, "cannot write there")]:
        code, _, err = run_cli("export", npz, "--formats", "csv", "--out", out)
        one_line_error(code, err, needle)


def test_lift_out_paths(run_cli, data_dir, tmp_path, read_only_folder):
    keypoints = data_dir / POSE2SIM / "openpose-body25b/cam01_json"
    (tmp_path / "file").write_text("x")
    for out, needle in [(tmp_path / "file", "is a file"), (read_only_folder, "cannot write there")]:
        code, _, err = run_cli(
            "lift", "--keypoints", keypoints, "--fps", "60", "--image-size", "1920x1088", "--out", out
        )
        one_line_error(code, err, needle)
