"""Streaming results: frames leave ``lift_stream`` as soon as they are final, with the whole-array numbers."""

import numpy as np
import pytest

from platypose.lifting.settings import SamplerConfig, WindowSettings
from platypose.lifting.timebase import interpolate, resample_keypoints
from platypose.lifting.tracks import stream as lift_module
from platypose.lifting.tracks.stream import KeypointWindows, lift_stream, lift_tracks, prior_clock
from platypose.lifting.tracks.windows import cut, plan_windows, stitch

TAKE = "video/pose2sim-balancing"


@pytest.fixture(scope="module")
def real_track(data_dir):
    """The athlete's OpenPose keypoints seen by cam01 (C=1, T, P=1, 17, 3) at 60 fps, and the camera."""
    from platypose.detectors.sources.keypoint_source import read_keypoints
    from platypose.detectors.tracking.tracker import persons_to_keep
    from platypose.lifting.calibration import load_calibration

    camera = load_calibration(data_dir / TAKE / "calib_pose2sim.toml").cameras[0]
    view = read_keypoints(data_dir / TAKE / "openpose-body25b/cam01_json", fps=60.0, image_size=(1080, 1920))
    athlete = int(persons_to_keep([view], "largest")[0])
    return view.keypoints[None, :, [athlete]], view.frame_times, camera


@pytest.mark.parametrize("step", [1, 10], ids=["60fps", "6fps"])
def test_streamed_frames_equal_stitching_the_whole_track(tiny_prior, real_track, monkeypatch, step):
    """Every sampled window is recorded; stitching and resampling them whole gives the streamed numbers bit for bit.

    At 6 fps (every 10th frame) input frames lie five prior frames apart, so the input frame after a finished stretch
    lies past the next window's start: the frames that window still adds to must be kept (they were dropped, and
    the window's sum then broadcast 2 frames against 16)."""
    keypoints, times, camera = real_track
    keypoints, times = keypoints[:, ::step], times[::step]
    windows: list[tuple[np.ndarray, np.ndarray]] = []
    sample = lift_module.sample

    def recording_sample(*args, **kwargs):
        result = sample(*args, **kwargs)
        windows.append((np.asarray(result.joints, np.float32), np.asarray(result.energy, np.float32)))
        return result

    monkeypatch.setattr(lift_module, "sample", recording_sample)
    settings = WindowSettings(window=16, overlap=4)
    chunks = list(lift_stream(tiny_prior, [camera], keypoints, times, SamplerConfig(samples=3), settings))
    clock = prior_clock(times, tiny_prior.fps)
    plan = plan_windows(len(clock), 16, 4)
    assert len(windows) == plan.count > 3
    sizes = [c.hypotheses.shape[2] for c in chunks]
    assert len(chunks) > 3 and [c.start for c in chunks] == np.cumsum([0] + sizes[:-1]).tolist()
    joints = np.stack([j for j, _ in windows])  # (W, P, N, F, 17, 3)
    energy = np.stack([e for _, e in windows])
    whole = interpolate(stitch(np.moveaxis(joints, 3, 1), plan), clock, times)  # (T, P, N, 17, 3)
    whole_energy = interpolate(stitch(np.moveaxis(energy, 3, 1), plan), clock, times)
    streamed = np.concatenate([c.hypotheses for c in chunks], axis=2)
    assert streamed.shape == (1, 3, len(times), 17, 3) and np.isfinite(streamed).all()
    assert np.array_equal(streamed, np.moveaxis(whole, 0, 2).astype(np.float32))
    streamed_energy = np.concatenate([c.energy for c in chunks], axis=2)
    assert np.array_equal(streamed_energy, np.moveaxis(whole_energy, 0, 2).astype(np.float32))


def test_windows_cut_and_resample_like_the_whole_track(real_track):
    keypoints, times = real_track[0], real_track[1]  # (C, T, P, 17, 3) at 60 fps, some joints missing
    assert (keypoints[..., 2] == 0).any()
    clock = prior_clock(times, 25.0)
    plan = plan_windows(len(clock), 15, 4)
    assert plan.padded_total > len(clock)  # the last window is padded
    whole = np.moveaxis(resample_keypoints(np.moveaxis(keypoints, 1, 0), times, clock), 0, 1)  # (C, T', P, 17, 3)
    windows = cut(np.moveaxis(whole, 2, 1), plan, axis=2)
    resampled = KeypointWindows(keypoints, times, clock)
    for w, start in enumerate(plan.starts):
        assert np.array_equal(resampled.window(int(start), 15, [0]), windows[w], equal_nan=True)
    stopped = resampled.window(0, 15, [0], stop=10)  # frames from the span's end on are missing
    assert np.isnan(stopped[:, :, 10:, :, :2]).all() and (stopped[:, :, 10:, :, 2] == 0).all()
    assert np.array_equal(stopped[:, :, :10], windows[0][:, :, :10], equal_nan=True)
    one = KeypointWindows(keypoints[:, :1], times[:1], clock[:1]).window(0, 1, [0])  # a single frame
    expected = resample_keypoints(np.moveaxis(keypoints[:, :1], 1, 0), times[:1], clock[:1])  # (1, C, P, 17, 3)
    assert one.shape == (1, 1, 1, 17, 3) and np.array_equal(one, np.moveaxis(expected, 0, 2), equal_nan=True)


def test_lift_tracks_gathers_the_stream(tiny_prior, real_track):
    keypoints, times, camera = real_track
    settings = WindowSettings(window=16, overlap=4)
    out = lift_tracks(tiny_prior, [camera], keypoints[:, :40], times[:40], SamplerConfig(samples=2), settings)
    chunks = list(lift_stream(tiny_prior, [camera], keypoints[:, :40], times[:40], SamplerConfig(samples=2), settings))
    assert np.array_equal(out.hypotheses, np.concatenate([c.hypotheses for c in chunks], axis=2))
    assert out.hypotheses.shape == (1, 2, 40, 17, 3) and out.energy.shape == (1, 2, 40)


def test_a_single_frame_is_one_chunk(tiny_prior, real_track):
    keypoints, times, camera = real_track
    chunks = list(lift_stream(tiny_prior, [camera], keypoints[:, :1], times[:1], SamplerConfig(samples=2)))
    assert len(chunks) == 1 and chunks[0].start == 0 and chunks[0].hypotheses.shape == (1, 2, 1, 17, 3)
