"""Guidance's moves carried over the joints no camera sees (:mod:`platypose.lifting.sampling.unseen`)."""

from __future__ import annotations

import numpy as np
import torch

from platypose.lifting.floor import CALIBRATED_FLOOR
from platypose.lifting.motion_io import load_motion_paths
from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.offline.evaluation import centred_gap, look_target, place_window, window_keypoints
from platypose.lifting.sampling.sampler import cameras_and_rays, sample
from platypose.lifting.sampling.unseen import bridged_moves
from platypose.lifting.settings import SamplerConfig
from platypose.lifting.timebase import resample


def _moves(frames: int, values: dict[int, float]) -> torch.Tensor:
    """Moves ``(3, 1, 2, frames, 2)``: joint 0's x component takes ``values`` (frame: move), every other 0."""
    moved = torch.zeros(3, 1, 2, frames, 2, dtype=torch.float64)
    for frame, value in values.items():
        moved[0, 0, :, frame, 0] = value
    return moved


def test_an_unseen_stretch_takes_the_moves_of_its_seen_ends_fading_with_distance():
    known = torch.ones(1, 12, 2, dtype=torch.bool)
    known[0, 1:11, 0] = False  # joint 0 unseen in frames 1-10; joint 1 seen throughout
    bridge = bridged_moves(_moves(12, {0: 1.0, 11: 3.0}), known, fade_frames=4.0)
    expected = [0, 0.75, 0.5, 0.25, 0, 0, 0, 0, 0.75, 1.5, 2.25, 0]  # each end's move over its 4 nearest frames
    np.testing.assert_allclose(bridge[0, 0, 0, :, 0].numpy(), expected, atol=1e-12)
    np.testing.assert_allclose(bridge[0, 0, 1, :, 0].numpy(), expected, atol=1e-12)  # every hypothesis alike
    assert not bridge[1:].any() and not bridge[..., 1].any()  # other components, the seen joint: nothing


def test_a_short_stretch_shares_its_ends_moves_and_an_open_one_is_left_to_the_next_window():
    known = torch.zeros(1, 8, 2, dtype=torch.bool)
    known[0, [0, 2, 3], :] = True  # frame 1 between two seen frames; 4-7 run to the window's end
    bridge = bridged_moves(_moves(8, {0: 1.0, 2: 3.0, 3: 5.0}), known, fade_frames=4.0)
    assert bridge[0, 0, 0, 1, 0] == 2.0  # weights 0.75 and 0.75, divided by their sum: the mean
    assert not bridge[0, 0, 0, 4:].any()  # nothing after the last seen frame
    assert not bridge[0, 0, 0, [0, 2, 3]].any()  # seen frames keep their own moves


def test_the_sampler_moves_on_smoothly_into_a_one_view_gap(data_dir):
    """One view, a centred 1 s gap in a 64-frame window of real motion (CMU 11-01, unseen by the prior): the
    sampler's motion steps at the gap's edges less than 4 times its median step elsewhere (pelvis-relative joints,
    mean over joints and hypotheses). Without the bridge: 7.8-9.6 times, a 100 mm jump in ``eval --gap 1``."""
    from platypose.lifting.prior.model import load_prior

    torch.set_num_threads(1)
    prior = load_prior()[0]
    clip = load_motion_paths([data_dir / "motion" / "cmu-11-01"])[0]
    window = resample(clip.joints, clip.fps, prior.fps)[:64]
    cameras = ring_cameras(4)[:1]
    hidden = centred_gap(64, 1.0, prior.fps)
    truth = place_window(window - window[:, 0].mean(0) + [0.0, 0.0, 1.0], look_target(cameras), 0.0)[None]
    keypoints = window_keypoints(cameras, truth, 0.0, 0, hidden)
    obs, rays = cameras_and_rays(cameras, np.nan_to_num(keypoints[..., :2]), keypoints[..., 2])
    config = SamplerConfig(samples=8, seed=0, floor=CALIBRATED_FLOOR.plane)
    joints = sample(prior, obs, rays, config, 64).joints[0]
    relative = joints - joints[..., :1, :]
    steps = np.linalg.norm(np.diff(relative, axis=1), axis=-1).mean(axis=(0, 2))  # (63,)
    first, last = np.flatnonzero(hidden)[[0, -1]]
    edges = max(steps[first - 1], steps[last])
    elsewhere = np.median(np.delete(steps, [first - 1, last]))
    assert edges < 4 * elsewhere, (edges, elsewhere)
