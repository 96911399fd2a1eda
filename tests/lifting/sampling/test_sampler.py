"""The guided sampler (lifting/sampling/sampler.py) with a small prior trained on real clips in the test session."""

import numpy as np
import torch
from ring_lifts import ring_lift, rms_px

from platypose.lifting.camera import project
from platypose.lifting.offline import metrics
from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.sampling.sampler import cameras_and_rays, sample
from platypose.lifting.settings import SamplerConfig


def test_four_views_collapse_onto_the_truth(tiny_prior, heldout_window):
    result, _ = ring_lift(tiny_prior, heldout_window, views=4, samples=20)
    hyps = result.joints[0]
    assert metrics.min_mpjpe(hyps, heldout_window) < 0.005  # a few mm on noise-free 2D
    assert metrics.root_error(hyps, heldout_window) < 0.01
    assert np.max(rms_px(result, 4)) < 1.0


def test_dpm2m_solver_in_four_network_calls_collapses_four_views_onto_the_truth(tiny_prior, heldout_window):
    result, _ = ring_lift(tiny_prior, heldout_window, views=4, samples=20, steps=6, skip=2, solver="dpm2m")
    assert metrics.min_mpjpe(result.joints[0], heldout_window) < 0.005


def test_a_lower_temperature_narrows_one_views_hypotheses(tiny_prior, heldout_window):
    """The initial noise is scaled by the temperature (the network's first input, exactly); below 1, pelvis-relative
    hypotheses spread less around their median, and every hypothesis still fits the image."""

    def lift(temperature: float) -> tuple[torch.Tensor, float, np.ndarray]:
        inputs = []
        hook = tiny_prior.model.register_forward_hook(lambda module, args, out: inputs.append(args[0].clone()))
        result, _ = ring_lift(tiny_prior, heldout_window, views=1, samples=40, temperature=temperature)
        hook.remove()
        relative = metrics.root_relative(result.joints[0])
        spread = float(np.linalg.norm(relative - np.median(relative, axis=0), axis=-1).mean())
        return inputs[0], spread, rms_px(result, 1)

    first_wide, wide, _ = lift(1.0)
    first_narrow, narrow, rms = lift(0.5)
    assert torch.allclose(first_narrow, 0.5 * first_wide)
    assert narrow < 0.95 * wide, (narrow, wide)
    assert rms.max() < 1.0


def test_guidance_reaches_the_noise_level_of_the_2d_input(tiny_prior, heldout_window):
    for views in (4, 1):  # the fit itself, before the noise spread
        result, _ = ring_lift(tiny_prior, heldout_window, views=views, noise_px=2.0, samples=20, noise_spread=False)
        rms = rms_px(result, views)
        noise_rms = np.sqrt(2) * 2.0
        # every hypothesis fits down to the noise itself (a fit absorbs part of it, more so with one view)
        assert rms.max() < noise_rms, (views, rms.max())
        if views == 4:
            assert rms.min() > 0.6 * noise_rms, rms.min()  # 136 observations, 51 unknowns per frame: no overfit


def test_one_view_hypotheses_spread_along_depth(tiny_prior, heldout_window):
    result, cams = ring_lift(tiny_prior, heldout_window, views=1, samples=40)
    cam = cams[0]
    in_camera = result.joints[0] @ cam.R.T + cam.t  # (N, F, 17, 3) camera frame, z = depth
    spread = in_camera.std(axis=0).mean(axis=(0, 1))  # per axis: x, y (image plane), z (depth)
    assert spread[2] > 3 * spread[:2].max(), spread
    assert spread[2] > 0.05  # several centimetres of depth ambiguity, not a collapse
    assert rms_px(result, 1).max() < 1.0  # yet every one of them fits the image


def test_lambda_sweep_over_two_decades_is_smooth(tiny_prior, heldout_window):
    scales = [0.1, 0.3, 1.0, 3.0, 10.0]
    errors = []
    for scale in scales:
        result, _ = ring_lift(
            tiny_prior, heldout_window, views=4, noise_px=1.0, samples=10, energy_scale=scale, noise_spread=False
        )
        errors.append(np.median(rms_px(result, 4)))
    errors = np.array(errors)
    assert np.all(np.isfinite(errors))
    assert errors.max() < np.sqrt(2) * 1.0  # all reach the 1 px noise level
    assert np.all(np.abs(np.diff(np.log(errors))) < np.log(1.5)), errors  # neighbours within a factor 1.5


def test_paper_step_rule_is_available_and_backtracking_is_no_worse(tiny_prior, heldout_window):
    paper, _ = ring_lift(
        tiny_prior,
        heldout_window,
        views=4,
        samples=10,
        step_rule="paper",
        direction="gradient",
        energy_scale=30.0,
        noise_fit=False,
    )
    robust, _ = ring_lift(tiny_prior, heldout_window, views=4, samples=10, noise_fit=False)
    assert np.median(rms_px(robust, 4)) <= np.median(rms_px(paper, 4))


def test_known_root_trajectory_is_used(tiny_prior, heldout_window):
    cams = ring_cameras(4)[:1]
    pixels = np.stack([project(heldout_window, c) for c in cams])[:, None]
    obs, _ = cameras_and_rays(cams, pixels, np.ones(pixels.shape[:-1]))
    root = torch.as_tensor(heldout_window[None, :, 0], dtype=torch.float32)
    result = sample(tiny_prior, obs, None, SamplerConfig(samples=8), frames=16, root_trajectory=root)
    assert np.allclose(result.joints[0, :, :, 0], heldout_window[None, :, 0], atol=1e-5)


def test_sampling_is_reproducible_for_a_seed(tiny_prior, heldout_window):
    a, _ = ring_lift(tiny_prior, heldout_window, views=1, samples=6, seed=3)
    b, _ = ring_lift(tiny_prior, heldout_window, views=1, samples=6, seed=3)
    c, _ = ring_lift(tiny_prior, heldout_window, views=1, samples=6, seed=4)
    assert np.array_equal(a.joints, b.joints)
    assert not np.allclose(a.joints, c.joints)


def test_structural_energies_lower_bone_length_variation(tiny_prior, heldout_window):
    from platypose.lifting.skeleton import bone_lengths

    plain, _ = ring_lift(tiny_prior, heldout_window, views=1, noise_px=3.0, samples=10)
    structured, _ = ring_lift(
        tiny_prior, heldout_window, views=1, noise_px=3.0, samples=10, bone_weight=10.0, symmetry_weight=10.0
    )

    def variation(result):
        return bone_lengths(result.joints[0]).std(axis=1).mean()

    assert variation(structured) < variation(plain)
