"""``platypose eval --gap``: every window also lifted with a centred gap no camera sees, scored inside and outside it."""

from __future__ import annotations

import json

import numpy as np

from platypose.lifting.floor import CALIBRATED_FLOOR
from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.offline.evaluation import (
    centred_gap,
    lift_as_take,
    look_target,
    place_window,
    window_keypoints,
)
from platypose.lifting.settings import SamplerConfig, WindowSettings
from platypose.lifting.take import Take
from platypose.lifting.tracks.persons import root_paths
from platypose.pipeline import lift_take

WALK = "motion/deepmimic/humanoid3d_walk.txt"


def test_the_gap_is_centred_and_leaves_a_seen_frame_on_either_side():
    assert np.flatnonzero(centred_gap(16, 0.2, 30.0)).tolist() == [5, 6, 7, 8, 9, 10]
    assert np.flatnonzero(centred_gap(64, 1.0, 30.0)).tolist() == list(range(17, 47))
    longest = centred_gap(16, 10.0, 30.0)  # longer than the window: all but its first and last frame
    assert not longest[0] and not longest[-1] and longest.sum() == 14


def test_frames_inside_the_gap_give_the_lift_nothing(tiny_prior, heldout_window):
    """The truth inside the gap may be anything: the hypotheses are the same (no keypoints, no reprojection
    energy there), and differ from a lift that sees those frames."""
    cameras = ring_cameras(4)[:1]
    hidden = centred_gap(16, 0.2, tiny_prior.fps)
    config = SamplerConfig(samples=4, seed=5, floor=CALIBRATED_FLOOR.plane)
    truth = place_window(heldout_window, look_target(cameras), 0.0)[None]
    moved = truth.copy()
    moved[:, hidden] += [0.5, -0.3, 0.2]  # a different motion inside the gap only
    a, _ = lift_as_take(tiny_prior, cameras, truth, config, 0.0, hidden)
    b, _ = lift_as_take(tiny_prior, cameras, moved, config, 0.0, hidden)
    np.testing.assert_array_equal(a, b)
    seen, _ = lift_as_take(tiny_prior, cameras, moved, config, 0.0)
    assert np.abs(seen[:, :, hidden] - b[:, :, hidden]).max() > 0.1


def test_the_gap_rows_lift_a_window_as_lift_lifts_a_take(tiny_prior, heldout_window):
    """``eval --gap`` goes through the take path a real lift of a take with a gap runs (windows, anchors, placement
    across the gap, steady depth, bodies): its hypotheses and answer are those of :func:`platypose.pipeline.lift_take`
    on the same keypoints (it lifted each window alone before)."""
    cameras = ring_cameras(4)[:1]
    hidden = centred_gap(16, 0.2, tiny_prior.fps)
    config = SamplerConfig(samples=4, seed=3, floor=CALIBRATED_FLOOR.plane)
    truth = np.stack([place_window(heldout_window, look_target(cameras), 0.0)] * 2)
    hypotheses, answer = lift_as_take(tiny_prior, cameras, truth, config, 0.0, hidden)
    keypoints = np.moveaxis(window_keypoints(cameras, truth, 0.0, config.seed, hidden), 1, 2)
    times = np.arange(16) / tiny_prior.fps
    roots = root_paths(keypoints, times, cameras)
    take = Take.on_clock(keypoints, times, np.arange(2), cameras, roots, sampler=config, windows=WindowSettings())
    lifted = lift_take(tiny_prior, take, floor=CALIBRATED_FLOOR)
    np.testing.assert_allclose(hypotheses, lifted.hypotheses, atol=1e-5)
    np.testing.assert_allclose(answer, lifted.median, atol=1e-5)


def test_eval_gap_adds_rows_inside_and_outside_the_gap(run_cli, prior_file, data_dir, tmp_path):
    out_json = tmp_path / "eval.json"
    args = ["--frames", "16", "--samples", "6", "--windows", "2", "--views", "4", "--no-baseline"]
    code, out, err = run_cli("eval", data_dir / WALK, "--prior", prior_file, *args, "--gap", "0.2", "--json", out_json)
    assert code == 0, err
    assert "gap inside 0.2s" in out and "gap outside 0.2s" in out
    table = json.loads(out_json.read_text())
    assert table["gap_s"] == 0.2
    rows = {r["method"]: r for r in table["rows"]}
    assert list(rows) == ["platypose", "take", "gap inside 0.2s", "gap outside 0.2s"]
    assert all(r["frames"] == 16 and r["windows"] == 2 and r["samples"] == 6 for r in rows.values())
    plain, take, inside, outside = (rows[m]["values"] for m in rows)
    assert take["minMPSPE"] < 15.0  # the take path seeing every frame
    assert outside["minMPSPE"] < 15.0  # mm: 4 views, exact 2D on the seen frames
    assert inside["minMPSPE"] > 2 * outside["minMPSPE"]  # unseen: only the prior there
    assert inside["minMPSPE"] > plain["minMPSPE"]
    assert 0 <= inside["ECE"] <= 1
    code, _, err = run_cli("eval", data_dir / WALK, "--prior", prior_file, "--gap", "-1")
    assert code == 2 and "--gap -1" in err and len(err.strip().splitlines()) == 1


def test_a_gap_longer_than_the_window_is_labelled_with_what_it_hid(run_cli, prior_file, tiny_prior, data_dir):
    """``--gap 10`` on 16-frame windows hides all but their first and last frame: the rows say those seconds."""
    used = centred_gap(16, 10.0, tiny_prior.fps).sum() / tiny_prior.fps
    args = ["--frames", "16", "--samples", "2", "--windows", "1", "--views", "1", "--no-baseline", "--gap", "10"]
    code, out, err = run_cli("eval", data_dir / WALK, "--prior", prior_file, *args)
    assert code == 0, err
    assert f"gap inside {used:g}s" in out and f"gap outside {used:g}s" in out and "10s" not in out, out


def test_a_gap_beyond_a_day_is_one_line(run_cli, prior_file, data_dir):
    """Finite but huge (1e308 overflowed the frame count) or not a number: one line naming --gap, exit 2."""
    for value, shown in (("1e308", "1e+308"), ("nan", "nan"), ("86401", "86401")):
        code, _, err = run_cli("eval", data_dir / WALK, "--prior", prior_file, "--gap", value)
        assert code == 2 and len(err.strip().splitlines()) == 1, err
        assert f"--gap {shown}: give a number of seconds from 0 to 86400 (a day)" in err
