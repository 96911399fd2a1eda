"""The guided sampler with a small prior trained on real clips in the test session."""

import numpy as np
import pytest
import torch

from lifting import metrics
from lifting.camera import project
from lifting.camera_rigs import ring_cameras
from lifting.sampler import SamplerConfig, cameras_and_rays, sample


def _lift(prior, truth, views, noise_px=0.0, **config):
    cams = ring_cameras(4)[:views]
    pixels = np.stack([project(truth, c) for c in cams])[:, None]
    if noise_px:
        pixels = pixels + np.random.default_rng(7).normal(0, noise_px, pixels.shape)
    obs, rays = cameras_and_rays(cams, pixels, np.ones(pixels.shape[:-1]))
    result = sample(prior, obs, rays, SamplerConfig(**config), frames=len(truth))
    return result, cams


def _rms_px(result, views, width=1000):
    """Per-hypothesis RMS of the 2D reprojection error vector in pixels, (N,).

    Gaussian noise of sigma px per coordinate has an RMS 2D error of sqrt(2) sigma.
    """
    per_keypoint = result.energy[0].sum(-1) / (len(result.energy[0][0]) * 17 * views)
    return np.sqrt(per_keypoint) * width / 2


def test_four_views_collapse_onto_the_truth(tiny_prior, heldout_window):
    result, _ = _lift(tiny_prior, heldout_window, views=4, samples=20)
    hyps = result.joints[0]
    assert metrics.min_mpjpe(hyps, heldout_window) < 0.005  # a few mm on noise-free 2D
    assert metrics.root_error(hyps, heldout_window) < 0.01
    assert np.max(_rms_px(result, 4)) < 1.0


def test_guidance_reaches_the_noise_level_of_the_2d_input(tiny_prior, heldout_window):
    for views in (4, 1):
        result, _ = _lift(tiny_prior, heldout_window, views=views, noise_px=2.0, samples=20)
        rms = _rms_px(result, views)
        noise_rms = np.sqrt(2) * 2.0
        # every hypothesis fits down to the noise itself (a fit absorbs part of it, more so with one view)
        assert rms.max() < noise_rms, (views, rms.max())
        if views == 4:
            assert rms.min() > 0.6 * noise_rms, rms.min()  # 136 observations, 51 unknowns per frame: no overfit


def test_one_view_hypotheses_spread_along_depth(tiny_prior, heldout_window):
    result, cams = _lift(tiny_prior, heldout_window, views=1, samples=40)
    cam = cams[0]
    in_camera = result.joints[0] @ cam.R.T + cam.t  # (N, F, 17, 3) camera frame, z = depth
    spread = in_camera.std(axis=0).mean(axis=(0, 1))  # per axis: x, y (image plane), z (depth)
    assert spread[2] > 3 * spread[:2].max(), spread
    assert spread[2] > 0.05  # several centimetres of depth ambiguity, not a collapse
    assert _rms_px(result, 1).max() < 1.0  # yet every one of them fits the image


def test_lambda_sweep_over_two_decades_is_smooth(tiny_prior, heldout_window):
    scales = [0.1, 0.3, 1.0, 3.0, 10.0]
    errors = []
    for scale in scales:
        result, _ = _lift(tiny_prior, heldout_window, views=4, noise_px=1.0, samples=10, energy_scale=scale)
        errors.append(np.median(_rms_px(result, 4)))
    errors = np.array(errors)
    assert np.all(np.isfinite(errors))
    assert errors.max() < np.sqrt(2) * 1.0  # all reach the 1 px noise level
    assert np.all(np.abs(np.diff(np.log(errors))) < np.log(1.5)), errors  # neighbours within a factor 1.5


def test_paper_step_rule_is_available_and_backtracking_is_no_worse(tiny_prior, heldout_window):
    paper, _ = _lift(tiny_prior, heldout_window, views=4, samples=10, step_rule="paper", direction="gradient",
                     energy_scale=30.0)  # fmt: skip
    robust, _ = _lift(tiny_prior, heldout_window, views=4, samples=10)
    assert np.median(_rms_px(robust, 4)) <= np.median(_rms_px(paper, 4))


def test_known_root_trajectory_is_used(tiny_prior, heldout_window):
    cams = ring_cameras(4)[:1]
    pixels = np.stack([project(heldout_window, c) for c in cams])[:, None]
    obs, _ = cameras_and_rays(cams, pixels, np.ones(pixels.shape[:-1]))
    root = torch.as_tensor(heldout_window[None, :, 0], dtype=torch.float32)
    result = sample(tiny_prior, obs, None, SamplerConfig(samples=8), frames=16, root_trajectory=root)
    assert np.allclose(result.joints[0, :, :, 0], heldout_window[None, :, 0], atol=1e-5)


def test_sampling_is_reproducible_for_a_seed(tiny_prior, heldout_window):
    a, _ = _lift(tiny_prior, heldout_window, views=1, samples=6, seed=3)
    b, _ = _lift(tiny_prior, heldout_window, views=1, samples=6, seed=3)
    c, _ = _lift(tiny_prior, heldout_window, views=1, samples=6, seed=4)
    assert np.array_equal(a.joints, b.joints)
    assert not np.allclose(a.joints, c.joints)


def test_structural_energies_lower_bone_length_variation(tiny_prior, heldout_window):
    from lifting.skeleton import bone_lengths

    plain, _ = _lift(tiny_prior, heldout_window, views=1, noise_px=3.0, samples=10)
    structured, _ = _lift(tiny_prior, heldout_window, views=1, noise_px=3.0, samples=10, bone_weight=10.0,
                          symmetry_weight=10.0)  # fmt: skip
    def variation(result):
        return bone_lengths(result.joints[0]).std(axis=1).mean()

    assert variation(structured) < variation(plain)


@pytest.mark.parametrize(
    "bad",
    [dict(samples=0), dict(robust="cauchy"), dict(skip=10), dict(energy_scale=-1.0), dict(step_rule="adam"),
     dict(decay=1.5)],
)  # fmt: skip
def test_bad_sampler_settings_are_refused(bad):
    with pytest.raises(ValueError):
        SamplerConfig(**bad)


def _problem(prior, truth, views, root=False, **config):
    """A guidance problem for ``truth`` seen by ``views`` ring cameras, and a network prediction ``x0`` for it."""
    from lifting.sampler import GuidedProblem

    cams = ring_cameras(4)[:views]
    pixels = np.stack([project(truth, c) for c in cams])[:, None]
    obs, rays = cameras_and_rays(cams, pixels, np.ones(pixels.shape[:-1]))
    path = torch.as_tensor(truth[None, :, 0], dtype=torch.float32) if root else None
    problem = GuidedProblem(prior, obs, None if root else rays, SamplerConfig(**config), path)
    with torch.inference_mode():
        x0 = prior.model(torch.randn(6, len(truth), prior.config.features, generator=torch.Generator().manual_seed(0)), 20)
    return problem, x0.clone()


@pytest.mark.parametrize("root", [False, True])
def test_moving_joints_then_absorbing_the_move_decodes_to_the_moved_joints(tiny_prior, heldout_window, root):
    problem, x0 = _problem(tiny_prior, heldout_window, views=1, root=root)
    offset = problem.solve_offset(x0)
    start = problem.world_joints(x0, offset).movedim(-1, 0)
    moved = 0.05 * torch.randn(start.shape, generator=torch.Generator().manual_seed(1))
    decoded = problem.world_joints(*problem.absorb(x0, offset, moved))
    assert torch.allclose(decoded, problem.displaced(start, moved).movedim(0, -1), atol=1e-5)
    if root:  # the pelvis stays on the known path
        assert torch.allclose(decoded[..., 0, :], problem.root_trajectory[:, None].expand_as(decoded[..., 0, :]), atol=1e-5)


def test_gradient_direction_moves_the_joints_as_a_step_down_the_feature_gradient(tiny_prior, heldout_window):
    from lifting.energy import reprojection_energy

    problem, x0 = _problem(tiny_prior, heldout_window, views=2, direction="gradient")
    offset = problem.solve_offset(x0)
    joints = problem.world_joints(x0, offset)
    _, direction = problem.evaluate(joints)
    x = x0.clone().requires_grad_(True)
    energy = reprojection_energy(problem.world_joints(x, offset), problem.obs).sum()
    (grad_x,) = torch.autograd.grad(energy, x)
    expected = problem.world_joints(x0 - grad_x, offset) - joints
    assert torch.allclose(direction.movedim(0, -1), expected, rtol=1e-3, atol=1e-5 * float(expected.abs().max()))


def test_guidance_stops_once_the_fit_gains_nothing_and_lands_where_k_steps_land(tiny_prior, heldout_window, monkeypatch):
    from lifting.sampler import GuidedProblem

    problem, x0 = _problem(tiny_prior, heldout_window, views=1)
    calls = []
    evaluate = GuidedProblem.evaluate
    monkeypatch.setattr(GuidedProblem, "evaluate", lambda self, *args: calls.append(1) or evaluate(self, *args))
    stopped = problem.world_joints(*problem.guide(x0, 10))
    early = len(calls)
    problem.config = SamplerConfig(guidance_tol=0.0)
    every = problem.world_joints(*problem.guide(x0, 10))
    assert early < 11 and len(calls) - early == 11  # exact 2D in one view: the rays are reached in a few steps
    assert (stopped - every).norm(dim=-1).max() < 1e-3  # metres


def test_one_view_guidance_in_the_camera_frame_equals_guidance_in_the_world(tiny_prior, heldout_window, monkeypatch):
    from lifting.sampler import Anchor, GuidedProblem

    problem, x0 = _problem(tiny_prior, heldout_window, views=1, guidance_tol=0.0, bone_weight=1.0)
    mask = (torch.arange(len(heldout_window)) < 4).float()[None]
    anchor_joints = torch.as_tensor(heldout_window, dtype=torch.float32).expand(1, 6, *heldout_window.shape)
    problem.anchor = Anchor(anchor_joints, mask)
    in_camera = problem.world_joints(*problem.guide(x0, 3))
    monkeypatch.setattr(GuidedProblem, "camera_frame", lambda self: None)
    in_world = problem.world_joints(*problem.guide(x0, 3))
    assert (in_camera - in_world).norm(dim=-1).max() < 1e-4  # metres
