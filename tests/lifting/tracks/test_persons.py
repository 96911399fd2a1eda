"""The take-level lift of the library (platypose.lifting.tracks.persons): root decisions and persons lifted into plain arrays."""

import numpy as np
import pytest

from platypose.lifting.camera import project
from platypose.lifting.errors import InputError
from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.settings import SamplerConfig, WindowSettings
from platypose.lifting.take import Take
from platypose.lifting.timebase import resample
from platypose.lifting.tracks.persons import lift_persons, root_paths
from platypose.lifting.tracks.roots import presence


def _take(real_clips, views: int, frames: int = 20):
    walk = next(m for m in real_clips if "walk" in m.name)
    motion = resample(walk.joints, walk.fps, 30.0)[:frames]
    motion = motion - motion[:, 0].mean(0) + [0.0, 0.0, 1.0]
    cams = ring_cameras(4)[:views]
    pixels = np.stack([project(motion, c) for c in cams])  # (C, T, 17, 2)
    keypoints = np.concatenate([pixels, np.ones(pixels.shape[:-1] + (1,))], -1)[:, :, None]  # (C, T, 1, 17, 3)
    return motion, keypoints, np.arange(frames) / 30.0, cams


def test_root_paths_follow_the_mode_and_the_cameras(real_clips):
    motion, keypoints, times, cams = _take(real_clips, 2)
    said = []
    (triangulated,) = root_paths(keypoints, times, cams, "auto", say=said.append)
    assert np.abs(triangulated - motion[:, 0]).max() < 1e-6 and "triangulated in 100% of frames" in said[0]
    assert root_paths(keypoints, times, cams, "solve") == [None]
    given = [np.zeros((len(times), 3))]
    assert root_paths(keypoints, times, cams, "triangulate", given)[0] is given[0]
    assert root_paths(keypoints[:1], times, cams[:1], "auto") == [None]
    with pytest.raises(InputError, match="root triangulate needs two or more calibrated views, got 1"):
        root_paths(keypoints[:1], times, cams[:1], "triangulate")
    with pytest.raises(InputError, match="root must be one of"):
        root_paths(keypoints, times, cams, "guess")


def test_persons_are_lifted_into_plain_arrays_with_nan_where_absent(real_clips, tiny_prior):
    motion, keypoints, times, cams = _take(real_clips, 2)
    keypoints[:, 15:, 0, :, 2] = 0  # no view sees the person from frame 15 on
    absent = ~presence(keypoints, times)
    assert absent[0, 15:].all() and not absent[0, :15].any()
    N, T = 3, len(times)
    hypotheses, median, energy = np.zeros((1, N, T, 17, 3)), np.zeros((1, T, 17, 3)), np.zeros((1, N, T))
    roots = root_paths(keypoints, times, cams)
    calls = []
    config = SamplerConfig(samples=N, steps=4, skip=1, guidance_iters=2)
    take = Take.on_clock(
        keypoints, times, np.arange(keypoints.shape[2]), cams, roots, sampler=config, windows=WindowSettings(16, 4)
    )
    assert np.array_equal(take.absent, absent)
    lift_persons(
        tiny_prior,
        take,
        hypotheses=hypotheses,
        median=median,
        energy=energy,
        progress=lambda group, done, total: calls.append((group, done, total)),
    )
    assert np.isnan(hypotheses[:, :, 15:]).all() and np.isnan(energy[:, :, 15:]).all()
    assert np.isfinite(hypotheses[:, :, :15]).all() and np.isfinite(median[:, :15]).all()
    assert np.allclose(median[0, :15], np.median(hypotheses[0, :, :15], axis=0))
    assert np.abs(hypotheses[0, :, :15, 0] - motion[None, :15, 0]).max() < 0.1  # near the triangulated root
    assert calls[-1][0] == [0] and calls[-1][1] == calls[-1][2] >= 1
