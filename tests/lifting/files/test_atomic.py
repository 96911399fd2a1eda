"""``lifting.files.atomic``: the target appears whole or not at all, and no temporary file is left behind."""

from __future__ import annotations

import csv
import json
import stat

import numpy as np
import pytest

from platypose.lifting.files.atomic import atomic_open, atomic_path, write_text_atomic


def test_write_text_replaces_target_and_leaves_no_temp(tmp_path):
    target = tmp_path / "sub" / "summary.json"
    target.parent.mkdir()
    target.write_text("old")
    assert write_text_atomic(target, json.dumps({"name": "müde", "n": 3})) == target
    assert json.loads(target.read_text(encoding="utf-8")) == {"name": "müde", "n": 3}
    assert stat.S_IMODE(target.stat().st_mode) == 0o644
    assert [p.name for p in target.parent.iterdir()] == ["summary.json"]


def test_binary_stream_is_read_back_by_numpy(tmp_path):
    target = tmp_path / "new" / "arrays.npz"  # the folder is created
    with atomic_open(target) as stream:
        np.savez(stream, x=np.arange(6.0).reshape(2, 3))
    with np.load(target) as data:
        assert data["x"].tolist() == [[0.0, 1.0, 2.0], [3.0, 4.0, 5.0]]


def test_text_stream_passes_open_arguments(tmp_path):
    target = tmp_path / "rows.csv"
    with atomic_open(target, "w", newline="") as stream:
        csv.writer(stream).writerows([["joint", "x"], ["pelvis", "1.5"]])
    assert target.read_bytes() == b"joint,x\r\npelvis,1.5\r\n"
    with open(target, newline="") as stream:
        assert list(csv.reader(stream)) == [["joint", "x"], ["pelvis", "1.5"]]


@pytest.mark.parametrize("writer", ["stream", "path"])
def test_error_keeps_the_old_target_and_removes_the_temp(tmp_path, writer):
    target = tmp_path / "calib.json"
    target.write_text('{"old": true}')
    with pytest.raises(RuntimeError, match="disk on fire"):
        if writer == "stream":
            with atomic_open(target, "w") as stream:
                stream.write('{"half": ')
                raise RuntimeError("disk on fire")
        else:
            with atomic_path(target) as tmp:
                tmp.write_text('{"half": ')
                raise RuntimeError("disk on fire")
    assert json.loads(target.read_text()) == {"old": True}
    assert [p.name for p in tmp_path.iterdir()] == ["calib.json"]


def test_long_target_names_up_to_the_file_system_limit(tmp_path):
    """Names over ~225 characters used to fail on the temporary name; 255 bytes now works."""
    target = tmp_path / ("n" * 251 + ".csv")
    assert write_text_atomic(target, "a,b\n").read_text() == "a,b\n"
    with pytest.raises(OSError):  # one more byte than the file system takes: the target itself cannot exist
        write_text_atomic(tmp_path / ("n" * 252 + ".csv"), "a,b\n")
    assert [p.name for p in tmp_path.iterdir()] == [target.name]
