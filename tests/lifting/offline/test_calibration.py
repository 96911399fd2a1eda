"""The one-view temperature fitted per window length on held-out clips, stored in the manifest, applied by the
sampler (one view only), and fitted by ``platypose calibrate-prior``."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from platypose.lifting.camera import project
from platypose.lifting.offline.calibration import calibration_clip_names, fit_temperatures
from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.prior.model import load_prior
from platypose.lifting.sampling.sampler import cameras_and_rays, sample
from platypose.lifting.settings import SamplerConfig
from platypose.lifting.timebase import resample


def lift(prior, truth, views, **config):
    cams = ring_cameras(4)[:views]
    pixels = np.stack([project(truth, c) for c in cams])[:, None]
    obs, rays = cameras_and_rays(cams, pixels, np.ones(pixels.shape[:-1]))
    return sample(prior, obs, rays, SamplerConfig(samples=6, **config), frames=len(truth)).joints


def calibrated(prior, by_frames):
    return replace(prior, manifest={**prior.manifest, "temperature": {"by_frames": by_frames}})


def test_the_temperature_follows_the_window_length_in_log_frames(tiny_prior):
    prior = calibrated(tiny_prior, {"1": 0.8, "16": 1.2, "64": 1.0})
    assert [prior.temperature_for(f) for f in (1, 16, 64, 200)] == pytest.approx([0.8, 1.2, 1.0, 1.0])
    assert prior.temperature_for(4) == pytest.approx(1.0)  # log 4 is halfway between log 1 and log 16
    assert tiny_prior.temperature_for(16) == 1.0  # never calibrated


def test_the_sampler_applies_it_to_one_view_only(tiny_prior, heldout_window):
    prior = calibrated(tiny_prior, {"1": 0.6, "16": 0.6})
    one_view = lift(prior, heldout_window, 1)
    assert np.array_equal(one_view, lift(tiny_prior, heldout_window, 1, temperature=0.6))
    assert not np.array_equal(one_view, lift(tiny_prior, heldout_window, 1))
    assert np.array_equal(lift(prior, heldout_window, 2), lift(tiny_prior, heldout_window, 2))


def test_the_fit_keeps_the_grid_temperature_of_smallest_ece(tiny_prior, real_clips):
    clips = [resample(m.joints, m.fps, 30.0) for m in real_clips if "walk" in m.name or "run" in m.name]
    prior = calibrated(tiny_prior, {"1": 0.3})  # set aside while fitting: the grid is the temperature itself
    grid = (0.4, 1.0, 1.8)
    fitted = fit_temperatures(prior, clips, ring_cameras(4)[0], [1, 8], SamplerConfig(samples=12), 3, grid)
    for frames in ("1", "8"):
        eces = {float(t): e for t, e in fitted["ece"][frames].items()}
        assert set(eces) == set(grid) and fitted["by_frames"][frames] == min(eces, key=eces.get)
        assert len(set(eces.values())) == 3  # the temperature changes the spread, and so the ECE
    again = fit_temperatures(tiny_prior, clips, ring_cameras(4)[0], [1, 8], SamplerConfig(samples=12), 3, grid)
    assert again == fitted


def test_calibrate_prior_writes_the_fit_into_the_manifest(run_cli, prior_file, data_dir, tmp_path):
    out = tmp_path / "calibrated.pt"
    folders = [data_dir / "motion/deepmimic", data_dir / "motion/holosoma-climb"]
    code, stdout, err = run_cli(
        "calibrate-prior", *folders, "--prior", prior_file, "--out", out, "--frames", "1,8",
        "--windows", "2", "--samples", "8", "--grid", "0.5,1,1.5",
    )  # fmt: skip
    assert code == 0, err
    before, _ = load_prior(prior_file)
    after, _ = load_prior(out)
    names = calibration_clip_names(before.manifest)
    assert names and after.manifest["temperature"]["clips"] == sorted(names)
    assert set(after.manifest["temperature"]["by_frames"]) == {"1", "8"}
    assert all(t in (0.5, 1.0, 1.5) for t in after.manifest["temperature"]["by_frames"].values())
    assert f"wrote {out}" in stdout and after.checksum != before.checksum
