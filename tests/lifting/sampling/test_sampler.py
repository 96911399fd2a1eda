"""The guided sampler with a small prior trained on real clips in the test session."""

import numpy as np
import pytest
import torch

from platypose.lifting.camera import project
from platypose.lifting.offline import metrics
from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.sampling.placement import DEPTH_RANGE, limit_depth, typical_size
from platypose.lifting.sampling.sampler import cameras_and_rays, sample
from platypose.lifting.settings import SamplerConfig
from platypose.lifting.skeleton import SIZE_BONES, TYPICAL_BONE_LENGTHS, bone_lengths


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


def test_dpm2m_solver_in_four_network_calls_collapses_four_views_onto_the_truth(tiny_prior, heldout_window):
    result, _ = _lift(tiny_prior, heldout_window, views=4, samples=20, steps=6, skip=2, solver="dpm2m")
    assert metrics.min_mpjpe(result.joints[0], heldout_window) < 0.005


def test_a_lower_temperature_narrows_one_views_hypotheses(tiny_prior, heldout_window):
    """The initial noise is scaled by the temperature (the network's first input, exactly); below 1, pelvis-relative
    hypotheses spread less around their median, and every hypothesis still fits the image."""

    def lift(temperature: float) -> tuple[torch.Tensor, float, np.ndarray]:
        inputs = []
        hook = tiny_prior.model.register_forward_hook(lambda module, args, out: inputs.append(args[0].clone()))
        result, _ = _lift(tiny_prior, heldout_window, views=1, samples=40, temperature=temperature)
        hook.remove()
        relative = metrics.root_relative(result.joints[0])
        spread = float(np.linalg.norm(relative - np.median(relative, axis=0), axis=-1).mean())
        return inputs[0], spread, _rms_px(result, 1)

    first_wide, wide, _ = lift(1.0)
    first_narrow, narrow, rms = lift(0.5)
    assert torch.allclose(first_narrow, 0.5 * first_wide)
    assert narrow < 0.95 * wide, (narrow, wide)
    assert rms.max() < 1.0


def test_guidance_reaches_the_noise_level_of_the_2d_input(tiny_prior, heldout_window):
    for views in (4, 1):  # the fit itself, before the noise spread
        result, _ = _lift(tiny_prior, heldout_window, views=views, noise_px=2.0, samples=20, noise_spread=False)
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
        result, _ = _lift(
            tiny_prior, heldout_window, views=4, noise_px=1.0, samples=10, energy_scale=scale, noise_spread=False
        )
        errors.append(np.median(_rms_px(result, 4)))
    errors = np.array(errors)
    assert np.all(np.isfinite(errors))
    assert errors.max() < np.sqrt(2) * 1.0  # all reach the 1 px noise level
    assert np.all(np.abs(np.diff(np.log(errors))) < np.log(1.5)), errors  # neighbours within a factor 1.5


def test_paper_step_rule_is_available_and_backtracking_is_no_worse(tiny_prior, heldout_window):
    paper, _ = _lift(
        tiny_prior,
        heldout_window,
        views=4,
        samples=10,
        step_rule="paper",
        direction="gradient",
        energy_scale=30.0,
        noise_fit=False,
    )
    robust, _ = _lift(tiny_prior, heldout_window, views=4, samples=10, noise_fit=False)
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
    from platypose.lifting.skeleton import bone_lengths

    plain, _ = _lift(tiny_prior, heldout_window, views=1, noise_px=3.0, samples=10)
    structured, _ = _lift(
        tiny_prior, heldout_window, views=1, noise_px=3.0, samples=10, bone_weight=10.0, symmetry_weight=10.0
    )

    def variation(result):
        return bone_lengths(result.joints[0]).std(axis=1).mean()

    assert variation(structured) < variation(plain)


@pytest.mark.parametrize(
    "bad",
    [
        dict(samples=0),
        dict(robust="cauchy"),
        dict(skip=10),
        dict(energy_scale=-1.0),
        dict(step_rule="adam"),
        dict(decay=1.5),
        dict(depth_smoothness=-1.0),
        dict(solver="heun"),
        dict(solver="dpm2m", eta=0.5),
        dict(temperature=0.0),
        dict(temperature=2.5),
    ],
)
def test_bad_sampler_settings_are_refused(bad):
    with pytest.raises(ValueError):
        SamplerConfig(**bad)


def test_depth_limit_keeps_every_root_in_front_and_near_the_others():
    """One view: roots too far, too near, beside or behind the camera come back within DEPTH_RANGE of the median
    depth, and never far sideways (a root just behind the camera was once thrown kilometres away)."""
    cam = ring_cameras(4)[0]
    R, t = torch.tensor(cam.R), torch.tensor(cam.t)
    rng = np.random.default_rng(3)
    in_camera = np.concatenate(
        [
            rng.normal([0, 0, 4], [0.3, 0.3, 0.5], (8, 3)),
            [[0.2, 0.1, 30.0], [0.3, 0.0, 2.0], [1.5, 0.2, 0.001], [0.4, -0.2, -0.4], [0.0, 0.0, -6.0]],
        ]
    )
    world = torch.tensor((in_camera - cam.t) @ cam.R)[None, :, None]  # (B=1, N=13, F=1, 3)
    limited = limit_depth(world, R, t)[0, :, 0].numpy() @ cam.R.T + cam.t  # back in camera axes
    median = np.median(in_camera[:, 2])
    assert np.all(limited[:, 2] >= median / DEPTH_RANGE - 1e-6) and np.all(limited[:, 2] <= median * DEPTH_RANGE + 1e-6)
    assert np.allclose(limited[:8], in_camera[:8])  # within range: untouched
    assert np.allclose(limited[8] / limited[8, 2], in_camera[8] / in_camera[8, 2])  # too far: along its own ray
    assert np.allclose(limited[9] / limited[9, 2], in_camera[9] / in_camera[9, 2])  # too near: along its own ray
    assert np.all(np.linalg.norm(limited[:, :2], axis=-1) < 0.5 * median)  # beside / behind: onto the median ray


def test_size_prior_scales_each_hypothesis_to_its_own_factor(heldout_window):
    poses = torch.tensor(np.stack([heldout_window, 1.3 * heldout_window]))[None]  # (B=1, N=2, F, 17, 3)
    factors = torch.tensor([0.9, 1.1], dtype=torch.float64)
    typical = sum(TYPICAL_BONE_LENGTHS[b] for b in SIZE_BONES)
    sized = typical_size(poses, factors)[0].numpy()
    size = np.median(bone_lengths(sized)[..., list(SIZE_BONES)].sum(-1), axis=-1)
    assert np.allclose(size, typical * factors.numpy(), rtol=1e-5)
    assert np.allclose(sized[:, :, 0], poses[0, :, :, 0].numpy())  # scaled about the pelvis
    same = typical_size(poses)[0].numpy()  # no factors: one scale for the window keeps relative sizes
    ratio = bone_lengths(same[1]).sum(-1) / bone_lengths(same[0]).sum(-1)
    assert np.allclose(ratio, 1.3)


def test_noise_spread_covers_the_truth_as_often_as_it_claims(tiny_prior, heldout_window):
    """4 views, 2 px noise: the fits collapse onto one point per joint that misses the truth by the triangulation
    error; spread by the residuals' noise, the truth falls inside a hypotheses' ball about their median about as
    often as the ball's share of hypotheses, and the spread adds no frame-to-frame jitter."""
    result, _ = _lift(tiny_prior, heldout_window, views=4, noise_px=2.0, samples=50)
    hyps, fitted = result.joints[0], result.fitted[0]
    median = np.median(hyps, axis=0)
    radius = np.linalg.norm(hyps - median, axis=-1)  # (N, F, 17)
    truth_distance = np.linalg.norm(heldout_window - median, axis=-1)  # (F, 17)
    for share in (0.5, 0.9):
        covered = np.mean(truth_distance < np.quantile(radius, share, axis=0))
        assert abs(covered - share) < 0.15, (share, covered)
    fitted_radius = np.linalg.norm(fitted - np.median(fitted, axis=0), axis=-1)
    assert np.mean(truth_distance < np.quantile(fitted_radius, 0.9, axis=0)) < 0.3  # collapsed: overconfident
    offsets = hyps - fitted
    change = np.linalg.norm(np.diff(offsets, axis=1), axis=-1)
    assert change.mean() < 0.1 * np.linalg.norm(offsets, axis=-1).mean(), (
        change.mean()
    )  # one draw per window: no jitter
    rms = _rms_px(result, 4)
    assert np.all((rms > 0.8 * np.sqrt(2) * 2.0) & (rms < 1.5 * np.sqrt(2) * 2.0)), (
        rms
    )  # as far from the 2D as the truth


def test_noise_spread_ignores_frames_without_a_fit():
    """A track's padding frames (no keypoints, joints NaN) leave the other frames' spread finite."""
    from platypose.lifting.sampling.noise_spread import unit_weight_variance

    energy = torch.tensor([[[1.0, 2.0, float("nan")], [3.0, 1.0, float("nan")]]])  # (B=1, N=2, F=3)
    confidence = torch.ones(2, 1, 3, 17)
    confidence[:, :, 2] = 0  # frame 2 unobserved
    variance = unit_weight_variance(energy, confidence)
    assert torch.allclose(variance, torch.tensor([3.0 / (2 * 17 * (2 * 2 - 3))]))  # median fit 3 over 34 redundant


def test_noise_free_views_get_no_spread(tiny_prior, heldout_window):
    result, _ = _lift(tiny_prior, heldout_window, views=4, samples=20)
    assert np.abs(result.joints - result.fitted).max() < 0.002
    one_view, _ = _lift(tiny_prior, heldout_window, views=1, noise_px=2.0, samples=5)
    assert np.array_equal(one_view.joints, one_view.fitted)  # one camera: nothing redundant to measure noise by


def _problem(prior, truth, views, root=False, **config):
    """A guidance problem for ``truth`` seen by ``views`` ring cameras, and a network prediction ``x0`` for it."""
    from platypose.lifting.sampling.guidance import GuidedProblem

    cams = ring_cameras(4)[:views]
    pixels = np.stack([project(truth, c) for c in cams])[:, None]
    obs, rays = cameras_and_rays(cams, pixels, np.ones(pixels.shape[:-1]))
    path = torch.as_tensor(truth[None, :, 0], dtype=torch.float32) if root else None
    problem = GuidedProblem(prior, obs, None if root else rays, SamplerConfig(**config), path)
    with torch.inference_mode():
        x0 = prior.model(
            torch.randn(6, len(truth), prior.config.features, generator=torch.Generator().manual_seed(0)), 20
        )
    return problem, x0.clone()


@pytest.mark.parametrize("root", [False, True])
def test_moving_joints_then_absorbing_the_move_decodes_to_the_moved_joints(tiny_prior, heldout_window, root):
    problem, x0 = _problem(tiny_prior, heldout_window, views=1, root=root)
    offset = problem.solve_offset(x0)
    start = problem.world_joints(x0, offset).movedim(-1, 0)
    moved = 0.05 * torch.randn(start.shape, generator=torch.Generator().manual_seed(1))
    decoded = problem.world_joints(*problem.apply_joint_moves(x0, offset, moved))
    assert torch.allclose(decoded, problem.displaced(start, moved).movedim(0, -1), atol=1e-5)
    if root:  # the pelvis stays on the known path
        assert torch.allclose(
            decoded[..., 0, :], problem.root_trajectory[:, None].expand_as(decoded[..., 0, :]), atol=1e-5
        )


def test_gradient_direction_moves_the_joints_as_a_step_down_the_feature_gradient(tiny_prior, heldout_window):
    from platypose.lifting.sampling.energy import reprojection_energy

    problem, x0 = _problem(tiny_prior, heldout_window, views=2, direction="gradient")
    offset = problem.solve_offset(x0)
    joints = problem.world_joints(x0, offset)
    _, direction = problem.evaluate(joints)
    x = x0.clone().requires_grad_(True)
    energy = reprojection_energy(problem.world_joints(x, offset), problem.obs).sum()
    (grad_x,) = torch.autograd.grad(energy, x)
    expected = problem.world_joints(x0 - grad_x, offset) - joints
    assert torch.allclose(direction.movedim(0, -1), expected, rtol=1e-3, atol=1e-5 * float(expected.abs().max()))


def test_guidance_stops_once_the_fit_gains_nothing_and_lands_where_k_steps_land(
    tiny_prior, heldout_window, monkeypatch
):
    from platypose.lifting.sampling.guidance import GuidedProblem

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
    from platypose.lifting.sampling.guidance import GuidedProblem
    from platypose.lifting.sampling.placement import Anchor

    problem, x0 = _problem(tiny_prior, heldout_window, views=1, guidance_tol=0.0, bone_weight=1.0)
    mask = (torch.arange(len(heldout_window)) < 4).float()[None]
    anchor_joints = torch.as_tensor(heldout_window, dtype=torch.float32).expand(1, 6, *heldout_window.shape)
    problem.anchor = Anchor(anchor_joints, mask)
    in_camera = problem.world_joints(*problem.guide(x0, 3))
    monkeypatch.setattr(GuidedProblem, "camera_frame", lambda self: None)
    in_world = problem.world_joints(*problem.guide(x0, 3))
    assert (in_camera - in_world).norm(dim=-1).max() < 1e-4  # metres


def test_straight_exact_paths_are_left_alone():
    """Keypoints of a straight 3D path without noise (second differences nearly zero) stay as they are."""
    from platypose.lifting.sampling.temporal_fit import keypoint_noise, smooth_keypoints

    cam = ring_cameras(4)[0]
    walk = np.zeros((16, 17, 3)) + np.linspace(0, 1, 17)[None, :, None] * [0, 0, 1.0] + [0, 0, 0.5]
    walk = walk + np.arange(16)[:, None, None] * [0.03, 0.0, 0.0]
    pixels = project(walk, cam)[None, None]
    obs, _ = cameras_and_rays([cam], pixels, np.ones(pixels.shape[:-1]), dtype=torch.float64)
    smoothed = smooth_keypoints(obs, keypoint_noise(obs)).normalized
    assert torch.isfinite(smoothed).all() and (smoothed - obs.normalized).abs().max() * cam.K[0, 0] < 0.01  # pixels


def test_keypoint_noise_is_measured_from_the_tracks_own_jitter(heldout_window):
    from platypose.lifting.sampling.temporal_fit import keypoint_noise

    cams = ring_cameras(4)
    pixels = np.stack([project(heldout_window, c) for c in cams])[:, None]  # (C, B=1, F, 17, 2)
    noisy = pixels + np.random.default_rng(3).normal(0, 3.0, pixels.shape)
    for observed, expected_px in ((pixels, None), (noisy, 3.0)):
        obs, _ = cameras_and_rays(cams, observed, np.ones(observed.shape[:-1]))
        measured_px = float(keypoint_noise(obs)[0]) / float(obs.pixel_scale[0])
        if expected_px is None:
            assert measured_px < 0.5, measured_px  # real walking alone: its accelerations are a fraction of a pixel
        else:
            assert abs(measured_px - expected_px) < 0.15 * expected_px, measured_px


def test_noise_fit_follows_the_keypoints_only_as_far_as_their_noise(tiny_prior, heldout_window):
    """4 views, 3 px noise: fitting every frame exactly puts the noise into the motion; the noise fit is nearer
    the truth and moves as smoothly as it; exact keypoints are fitted as before."""
    exact, _ = _lift(tiny_prior, heldout_window, views=4, noise_px=3.0, samples=10, noise_fit=False, noise_spread=False)
    fitted, _ = _lift(tiny_prior, heldout_window, views=4, noise_px=3.0, samples=10, noise_spread=False)
    truth_speed = np.linalg.norm(np.diff(heldout_window, axis=0), axis=-1).mean()
    error = [np.linalg.norm(r.joints[0] - heldout_window, axis=-1).mean() for r in (exact, fitted)]
    velocity_error = [metrics.mpjve(r.joints[0], heldout_window) for r in (exact, fitted)]
    assert error[1] < 0.8 * error[0], error
    assert velocity_error[1] < 0.5 * velocity_error[0] < truth_speed, (velocity_error, truth_speed)
    clean, _ = _lift(tiny_prior, heldout_window, views=4, samples=10, noise_spread=False)
    assert np.linalg.norm(clean.joints[0] - heldout_window, axis=-1).mean() < 0.002


def test_padding_frames_are_held_for_the_noise_fit_and_stay_missing(tiny_prior, heldout_window):
    """A track's last window is padded with frames without joints (NaN): the noise fit holds the nearest frame
    there (a banded solve cannot take NaN), fits the rest, and gives the padding back as NaN."""
    from platypose.lifting.sampling.temporal_fit import fit_to_noise, hold_nearest, keypoint_noise

    values = torch.arange(5.0).reshape(1, 1, 5, 1, 1).expand(1, 1, 5, 17, 3).clone()
    valid = torch.tensor([False, True, True, True, False]).reshape(1, 1, 5, 1).expand(1, 1, 5, 17)
    held = hold_nearest(values, valid)[0, 0, :, 0, 0]
    assert held.tolist() == [1.0, 1.0, 2.0, 3.0, 3.0]
    cams = ring_cameras(4)
    pixels = np.stack([project(heldout_window, c) for c in cams])[:, None]
    pixels = pixels + np.random.default_rng(5).normal(0, 2.0, pixels.shape)
    confidence = np.ones(pixels.shape[:-1])
    confidence[:, :, -3:] = 0.0
    obs, _ = cameras_and_rays(cams, pixels, confidence)
    joints = torch.as_tensor(np.repeat(heldout_window[None, None], 3, axis=1), dtype=torch.float32).clone()
    joints[:, :, -3:] = float("nan")
    fitted = fit_to_noise(joints, obs, keypoint_noise(obs), 30.0)
    assert torch.isnan(fitted[:, :, -3:]).all() and torch.isfinite(fitted[:, :, :-3]).all()


def test_one_view_keypoint_paths_are_smoothed_to_their_noise(tiny_prior, heldout_window):
    """One camera, 3 px noise: the smoothed keypoint paths are nearer the true projections than the noisy ones,
    exact keypoints stay as they are, and the lift moves less jerkily than one fitting every frame exactly."""
    from platypose.lifting.sampling.temporal_fit import keypoint_noise, smooth_keypoints

    cam = ring_cameras(4)[0]
    clean = project(heldout_window, cam)[None, None]  # (C, B, F, 17, 2)
    noisy = clean + np.random.default_rng(11).normal(0, 3.0, clean.shape)
    obs_noisy, _ = cameras_and_rays([cam], noisy, np.ones(noisy.shape[:-1]))
    obs_clean, _ = cameras_and_rays([cam], clean, np.ones(clean.shape[:-1]))
    smoothed = smooth_keypoints(obs_noisy, keypoint_noise(obs_noisy)).normalized
    error_before = (obs_noisy.normalized - obs_clean.normalized).norm(dim=-1).mean()
    error_after = (smoothed - obs_clean.normalized).norm(dim=-1).mean()
    assert error_after < 0.7 * error_before, (error_after, error_before)
    kept = smooth_keypoints(obs_clean, keypoint_noise(obs_clean)).normalized
    assert (kept - obs_clean.normalized).norm(dim=-1).max() * cam.K[0, 0] < 1.0  # pixels: the walk's own accelerations
    exact, _ = _lift(tiny_prior, heldout_window, views=1, noise_px=3.0, samples=10, noise_fit=False)
    fitted, _ = _lift(tiny_prior, heldout_window, views=1, noise_px=3.0, samples=10)
    jerk = [np.abs(np.diff(r.joints[0], 2, axis=1)).mean() for r in (exact, fitted)]
    assert jerk[1] < 0.7 * jerk[0], jerk
