"""The guidance problem (lifting/sampling/guidance.py): moves of the joints applied to the features, the
gradient direction, the stop when the fit gains nothing, and guidance in the camera frame."""

import numpy as np
import pytest
import torch

from platypose.lifting.camera import project
from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.sampling.sampler import cameras_and_rays
from platypose.lifting.settings import SamplerConfig


def _problem(prior, truth, views, root=False, **config):
    """A guidance problem for ``truth`` seen by ``views`` ring cameras, and a network prediction ``x0`` for it."""
    from platypose.lifting.sampling.guidance import GuidedProblem

    cams = ring_cameras(4)[:views]
    pixels = np.stack([project(truth, c) for c in cams])[:, None]
    obs, rays = cameras_and_rays(cams, pixels, np.ones(pixels.shape[:-1]))
    path = torch.as_tensor(truth[None, :, 0], dtype=torch.float32) if root else None
    problem = GuidedProblem(prior, obs, None if root else rays, SamplerConfig(**config), root_trajectory=path)
    with torch.inference_mode():
        x0 = prior.model(
            torch.randn(6, len(truth), prior.config.features, generator=torch.Generator().manual_seed(0)), 20
        )
    return problem, x0.clone()


@pytest.mark.parametrize("root", [False, True])
def test_moving_joints_then_applying_the_move_decodes_to_the_moved_joints(tiny_prior, heldout_window, root):
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
