"""``export()`` and the ``platypose info`` / ``platypose export`` commands on real motion and video."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from export_helpers import two_person_result

from platypose.exporters import export
from platypose.lifting.errors import InputError


@pytest.fixture(scope="module")
def result(data_dir):
    return two_person_result(data_dir)


def test_export_writes_every_format_and_fit_error_in_meta(result, tmp_path):
    written = export(result, tmp_path, "clip", ["npz", "csv", "bvh"], bvh="all")
    names = sorted(p.name for p in written)
    assert names == sorted(
        ["clip.npz", "clip.csv", "clip_gaps.json", "clip_p0.bvh", "clip_p7.bvh"]
        + [f"clip_p{t}_h{n:03d}.bvh" for t in (0, 7) for n in range(6)]
    )
    assert sorted(p.name for p in tmp_path.iterdir()) == names  # no temporary files left
    with np.load(tmp_path / "clip.npz") as raw:
        fit = json.loads(str(raw["meta"]))["bvh_fit_error"]
    assert set(fit) == {"p0", "p7"}
    assert 0 < fit["p0"]["median"]["mean_m"] < 0.01 and fit["p0"]["median"]["max_m"] < 0.06
    assert fit["p7"]["hypotheses"]["max_m"] >= fit["p7"]["hypotheses"]["mean_m"] > 0


def test_export_rejects_bad_options_before_writing(result, data_dir, tmp_path):
    out = tmp_path / "out"
    with pytest.raises(InputError, match="formats: unknown"):
        export(result, out, "clip", ["npz", "fbx"])
    with pytest.raises(InputError, match="bvh must be one of"):
        export(result, out, "clip", ["bvh"], bvh="some")
    with pytest.raises(InputError, match="no such video"):
        export(result, out, "clip", ["npz", "rrd"], video_paths={"cam01": data_dir / "missing.mp4"})
    assert not out.exists()


def test_info_and_export_commands(result, data_dir, tmp_path, run_cli):
    export(result, tmp_path, "clip", ["npz"])
    code, out, _ = run_cli("info", str(tmp_path / "clip.npz"))
    assert code == 0
    assert "2 person(s) x 6 hypotheses x 30 frames at 120.000 fps" in out
    assert "person 7: present in 25/30 frames" in out and "camera cam02: 1080x1920 px" in out
    code, out, err = run_cli(
        "export",
        str(tmp_path / "clip.npz"),
        "--formats",
        "csv,rrd",
        "--out",
        str(tmp_path / "re"),
        "--video",
        f"cam01={data_dir / 'video/pose2sim-balancing/cam01.mp4'}",
    )
    assert code == 0, err
    assert sorted(p.name for p in (tmp_path / "re").iterdir()) == [
        "clip.csv",
        "clip.rrd",
        "clip_gaps.json",
    ]
    with open(tmp_path / "re" / "clip.csv", newline="") as f:
        first = next(csv.DictReader(f))
    assert float(first["pelvis_x_m"]) == round(float(result.median[0, 0, 0, 0]), 3)


def test_commands_report_bad_input_with_exit_code_2(result, tmp_path, run_cli):
    (tmp_path / "broken.npz").write_bytes(b"PK\x03\x04 not really")
    code, _, err = run_cli("info", str(tmp_path / "broken.npz"))
    assert code == 2 and "broken.npz" in err and len(err.strip().splitlines()) == 1
    export(result, tmp_path, "clip", ["npz"])
    code, _, err = run_cli("export", str(tmp_path / "clip.npz"), "--video", "x.mp4")
    assert code == 2 and "CAMERA=PATH" in err
