"""The Python API: docs/api.md's example runs on the bundled take, and platypose.lift is the CLI's pipeline."""

import re
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import platypose
from platypose.data import VIDEO_DIR

DOCS = Path(__file__).resolve().parents[2] / "docs" / "api.md"
TAKE = VIDEO_DIR / "pose2sim-balancing"


@pytest.fixture
def tiny_default_prior(monkeypatch, prior_file):
    """The tiny prior in place of the shipped one (what ``Prior.load()`` and ``prior=None`` load)."""
    import platypose.lifting.prior.model as prior_module

    monkeypatch.setattr(prior_module, "DEFAULT_PRIOR", Path(prior_file))
    return prior_file


def test_the_documented_example_runs_on_the_bundled_take(tiny_default_prior, tmp_path, monkeypatch, capsys):
    (code,) = re.findall(r"```python\n(.*?)```", DOCS.read_text(encoding="utf-8"), re.S)
    monkeypatch.chdir(tmp_path)
    namespace: dict = {}
    exec(compile(code, str(DOCS), "exec"), namespace)
    result = namespace["result"]
    assert result.hypotheses.shape == (1, 20, 100, 17, 3) and len(result.cameras) == 4
    assert sorted(result.meta["reprojection_px"]) == sorted(c.name for c in result.cameras)
    assert result.meta["root"] == ["triangulated"]
    assert (tmp_path / "out" / "api" / "balancing.npz").is_file()
    assert any(p.suffix == ".bvh" for p in (tmp_path / "out" / "api").iterdir())
    printed = capsys.readouterr().out
    assert "(1, 20, 100, 17, 3)" in printed and "m above the floor" in printed


def test_lift_gives_what_the_command_writes(tiny_default_prior, run_cli, tmp_path):
    args = ["--keypoints", TAKE / "openpose-body25b", "--cams", TAKE / "calib_pose2sim.toml", "--persons", "largest"]
    options = ["--samples", "3", "--seed", "2", "--formats", "npz", "--threads", "1", "--out", tmp_path, "-q"]
    code, _, err = run_cli("lift", *args, *options)
    assert code == 0, err
    written = platypose.load_result(tmp_path / "openpose-body25b" / "openpose-body25b.npz")
    views = sorted((TAKE / "openpose-body25b").iterdir())
    lines: list[str] = []
    result = platypose.lift(views, TAKE / "calib_pose2sim.toml", persons="largest", samples=3, seed=2, say=lines.append)
    assert np.array_equal(result.hypotheses, written.hypotheses, equal_nan=True)
    assert np.array_equal(result.energy, written.energy, equal_nan=True)
    assert [c.name for c in result.cameras] == [c.name for c in written.cameras]
    assert result.meta["reprojection_px"] == written.meta["reprojection_px"]
    assert any("pelvis triangulated" in line for line in lines)
    assert result.meta["arguments"]["sampler"]["samples"] == 3 and result.meta["arguments"]["persons"] == "largest"


def test_bad_input_is_an_input_error_naming_the_argument(tiny_default_prior):
    views = sorted((TAKE / "openpose-body25b").iterdir())
    with pytest.raises(platypose.InputError, match="persons must be"):
        platypose.lift(views, TAKE / "calib_pose2sim.toml", persons="tallest")
    with pytest.raises(platypose.InputError, match="2 views need cams"):
        platypose.lift(views[:2])
    with pytest.raises(platypose.InputError, match="samples must be at least 1"):
        platypose.lift(views[:1], samples=0)


def test_importing_platypose_loads_no_torch():
    code = "import sys, platypose; assert 'torch' not in sys.modules; platypose.SamplerConfig; print('ok')"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=120)
    assert done.returncode == 0 and done.stdout.strip() == "ok", done.stderr


def test_a_video_view_is_detected_and_lifted_as_the_command_does(tiny_default_prior, run_cli, tmp_path):
    import cv2

    from platypose.detectors.sources.video import iter_frames

    video = tmp_path / "cam01.mp4"  # the take's first 12 frames of cam01, halved
    frames = [f[::2, ::2].copy() for _, f in iter_frames(TAKE / "cam01.mp4", max_frames=12)]
    writer = cv2.VideoWriter(str(video), cv2.VideoWriter_fourcc(*"mp4v"), 60.0, frames[0].shape[1::-1])
    for frame in frames:
        writer.write(frame)
    writer.release()
    options = ["--samples", "3", "--stride", "2", "--formats", "npz", "--threads", "1", "--out", tmp_path / "out", "-q"]
    code, _, err = run_cli("lift", video, *options)
    assert code == 0, err
    written = platypose.load_result(tmp_path / "out" / "cam01" / "cam01.npz")
    result = platypose.lift(video, samples=3, stride=2, threads=1)
    assert result.hypotheses.shape == written.hypotheses.shape and result.num_frames == 6
    assert np.array_equal(result.hypotheses, written.hypotheses, equal_nan=True)
    assert any(
        n.startswith("no cams: camera from the scene's lines") for n in result.meta["notes"]
    )  # a note, not a warning
    assert not any("no cams" in w for w in result.meta["warnings"])


def test_a_truncated_video_lifts_alike_both_ways(tiny_default_prior, run_cli, tmp_path):
    """The command and the API share one pipeline: one truncated real video is detected and lifted both ways with
    the same warnings (the truncated video's), notes (the calibration's coded image size) and hypotheses."""
    from media_helpers import truncated_copy

    video = truncated_copy(TAKE / "cam01.mp4", tmp_path / "cam01.mp4", 0.3)
    cams = TAKE / "calib_pose2sim.toml"
    options = ["--samples", "3", "--stride", "5", "--formats", "npz", "--threads", "1", "--out", tmp_path / "out"]
    code, _, err = run_cli("lift", video, "--cams", cams, *options, "-q")
    assert code == 0, err
    written = platypose.load_result(tmp_path / "out" / "cam01" / "cam01.npz")
    result = platypose.lift(video, cams, samples=3, stride=5, threads=1)
    warnings = result.meta["warnings"]
    assert any("states 100 frames but only" in w for w in warnings) and not any(
        "calibration says" in w for w in warnings
    )
    assert any("padding to a multiple of 16" in n for n in result.meta["notes"]) and "calibration says" not in err
    assert warnings == written.meta["warnings"] and f"warning: cam01: {warnings[0]}" in err
    assert result.hypotheses.shape == written.hypotheses.shape and result.num_frames < 10
    assert np.array_equal(result.hypotheses, written.hypotheses, equal_nan=True)
    assert result.meta["root"] == written.meta["root"] and result.meta["floor"] == written.meta["floor"]
