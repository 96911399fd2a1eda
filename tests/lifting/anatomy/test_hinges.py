"""Signed hinges and the joint-limit energy guidance adds (lifting/anatomy/hinges.py)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
import torch

from platypose.lifting.anatomy.hinges import HINGE_NAMES, limit_energy, signed_flexion
from platypose.lifting.skeleton import JOINT_INDEX as J

LIFTS = Path(__file__).parents[2] / "data" / "lifts"


def _bent(knee_deg: float, elbow_deg: float, neck_deg: float = 0.0) -> np.ndarray:
    """A standing pose (left +x, backwards +y, up +z) with both knees and elbows bent by signed angles."""
    p = np.zeros((17, 3))
    for name, xyz in {
        "pelvis": (0, 0, 1.0),
        "right_hip": (-0.085, 0, 1.0),
        "left_hip": (0.085, 0, 1.0),
        "spine": (0, 0, 1.24),
        "thorax": (0, 0, 1.48),
        "neck": (0, 0, 1.6),
        "left_shoulder": (0.18, 0, 1.48),
        "right_shoulder": (-0.18, 0, 1.48),
    }.items():
        p[J[name]] = xyz
    p[J["head"]] = p[J["neck"]] + 0.18 * np.array([0, -np.sin(np.radians(neck_deg)), np.cos(np.radians(neck_deg))])
    k, e = np.radians(knee_deg), np.radians(elbow_deg)
    for side in ("right", "left"):
        p[J[f"{side}_knee"]] = p[J[f"{side}_hip"]] + [0, 0, -0.42]
        p[J[f"{side}_ankle"]] = p[J[f"{side}_knee"]] + 0.41 * np.array([0, np.sin(k), -np.cos(k)])  # +y: back
        p[J[f"{side}_elbow"]] = p[J[f"{side}_shoulder"]] + [0, 0, -0.27]
        p[J[f"{side}_wrist"]] = p[J[f"{side}_elbow"]] + 0.26 * np.array([0, -np.sin(e), -np.cos(e)])  # -y: front
    return p


def test_signed_flexion_is_negative_bent_backwards_in_any_rigid_frame():
    turn = torch.linalg.matrix_exp(torch.tensor([[0.0, -0.7, 0.3], [0.7, 0.0, -0.5], [-0.3, 0.5, 0.0]])).double()
    for knee, elbow in ((40.0, 90.0), (-25.0, -15.0)):
        pose = _bent(knee, elbow)
        moved = pose @ turn.numpy().T + [3.0, -1.0, 0.5]
        for joints in (pose, moved):
            np.testing.assert_allclose(signed_flexion(joints), [knee, knee, elbow, elbow], atol=1e-6)


def test_limit_energy_costs_only_backward_knees_and_a_folded_neck():
    energy = lambda pose: float(limit_energy(torch.as_tensor(pose)))  # noqa: E731
    assert energy(_bent(60.0, 120.0, neck_deg=40.0)) == 0.0
    assert energy(_bent(-4.0, -4.0)) == 0.0  # straight, within the margin
    assert energy(_bent(-20.0, 0.0)) > 0.0 and energy(_bent(0.0, -20.0)) == 0.0  # elbows: sign only read
    assert energy(_bent(0.0, 0.0, neck_deg=85.0)) > 0.0
    assert energy(_bent(-30.0, 0.0)) > energy(_bent(-20.0, 0.0))


def test_descending_the_limit_energy_brings_a_real_lifts_hinges_forward():
    """The one-view lift of the Sports2D walker stored before the limits (tests/data/lifts) bends
    knees backwards in some frames; gradient steps on the energy alone bend them forwards and move joints little."""
    walker = np.load(LIFTS / "sports2d_demo_medians.npy")[1].astype(np.float64)
    joints = torch.as_tensor(walker[np.isfinite(walker).all(axis=(1, 2))])
    before = signed_flexion(joints.numpy())[..., :2]  # the knees
    assert (before < -10).any()
    x = joints.clone().requires_grad_(True)
    optimiser = torch.optim.SGD([x], lr=0.05)
    for _ in range(300):
        optimiser.zero_grad()
        limit_energy(x).sum().backward()
        optimiser.step()
    after = signed_flexion(x.detach().numpy())[..., :2]
    assert (after < -10).mean() < 0.5 * (before < -10).mean(), HINGE_NAMES
    assert float((x.detach() - joints).norm(dim=-1).max()) < 1.0  # at most a shin folded over


@pytest.mark.parametrize("weight", [0.0, 1.0])
def test_the_limit_weight_is_an_option_checked(weight):
    from platypose.lifting.settings import SamplerConfig

    assert SamplerConfig(limit_weight=weight).limit_weight == weight
    with pytest.raises(Exception, match="limit_weight"):
        SamplerConfig(limit_weight=-1.0)
