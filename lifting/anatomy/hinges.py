"""Which way the hinges of a body bend: signed knee and elbow flexion, the neck's bend, and an energy on their limits.

A knee or an elbow bends about one axis. Our 17 joints show the two bones of a hinge, not that axis, so it is
taken where the body carries it: the hinge axis of the limb hanging straight down (the body frame's ``left`` for
a knee, its ``-left`` for an elbow: a shin folds backwards, a forearm forwards) turned with the upper bone by the
shortest swing from hanging (the swing :mod:`exporters.angles` measures shoulder rotation from). Flexion is the
angle between the bones, positive where the bones turn the way that axis bends them (the OpenSim model's knee
and elbow coordinates, ``exporters/opensim_model.py``), negative where they turn the other way: a knee bent
backwards (hyperextended), or an elbow whose plane needs the upper arm turned past 90 degrees about itself.
Body frames: the pelvis's (right to left hip, pelvis to spine) for knees, the trunk's (right to left shoulder,
pelvis to thorax) for elbows.

:func:`limit_energy` is what guidance adds (``SamplerConfig.limit_weight``): per frame, the squared amount by
which each knee bends backwards (the sine of its bend against the carried axis, past a few degrees), and by
which the head's line bends from the trunk's past ``NECK_LIMIT_DEG`` (the :func:`limit_residuals`, whose
gradients give guidance its Gauss-Newton curvature). It is the same in any rigid frame.
"""

from __future__ import annotations

import math

import numpy as np
import torch

from platypose.lifting.skeleton import JOINT_INDEX as J

HINGE_NAMES: tuple[str, ...] = ("right_knee", "left_knee", "right_elbow", "left_elbow")
# per hinge: (upper joint, hinge joint, lower joint), the body frame it is carried in, the neutral axis's sign
_HINGES = (
    ("right_hip", "right_knee", "right_ankle", "pelvis", 1.0),
    ("left_hip", "left_knee", "left_ankle", "pelvis", 1.0),
    ("right_shoulder", "right_elbow", "right_wrist", "trunk", -1.0),
    ("left_shoulder", "left_elbow", "left_wrist", "trunk", -1.0),
)
# per hinge: the joint indices of its (upper, hinge, lower) joints
HINGE_JOINTS: tuple[tuple[int, int, int], ...] = tuple((J[top], J[mid], J[low]) for top, mid, low, _, _ in _HINGES)
OVERHEAD_DEG = 20.0
HYPEREXTENSION_MARGIN_DEG = 5.0  # a straight hinge's noise: bends backwards up to this cost nothing
NECK_LIMIT_DEG = 70.0
# The hinges the energy holds: the knees (the first two). An elbow's sign needs the upper arm's roll, which the
# carried axis only guesses (a raised arm's shortest swing is no roll a shoulder takes): held, four noise-free
# views of held-out mocap lost their truth (minMPJPE 186 mm).
LIMITED_HINGES = 2  # the head's line (neck to head) from the trunk's (spine to thorax), any direction


def _unit(v: torch.Tensor) -> torch.Tensor:
    return v / torch.linalg.vector_norm(v, dim=-1, keepdim=True).clamp(min=1e-9)


def _dot(a: torch.Tensor, b: torch.Tensor) -> torch.Tensor:
    return (a * b).sum(-1)


def _body_axes(joints: torch.Tensor) -> dict[str, tuple[torch.Tensor, torch.Tensor]]:
    """Unit (left, up) of the pelvis and the trunk, up made perpendicular to left, each ``(..., 3)``."""
    out = {}
    for name, left, right, top in (
        ("pelvis", "left_hip", "right_hip", "spine"),
        ("trunk", "left_shoulder", "right_shoulder", "thorax"),
    ):
        lateral = _unit(joints[..., J[left], :] - joints[..., J[right], :])
        up = joints[..., J[top], :] - joints[..., J["pelvis"], :]
        out[name] = lateral, _unit(up - _dot(up, lateral)[..., None] * lateral)
    return out


def carried_axis(axis: torch.Tensor, down: torch.Tensor, upper: torch.Tensor) -> torch.Tensor:
    """``axis`` turned by the shortest swing taking unit ``down`` onto unit ``upper`` (all ``(..., 3)``).

    Rodrigues' formula without dividing by the swing's sine: ``c v + w x v + w (w . v) / (1 + c)`` with
    ``w = down x upper``, ``c = down . upper``; undefined only for a bone pointing straight up.
    """
    w = torch.linalg.cross(down, upper)
    c = _dot(down, upper)[..., None]
    return c * axis + torch.linalg.cross(w, axis) + w * _dot(w, axis)[..., None] / (1.0 + c).clamp(min=1e-3)


def hinge_rests(joints: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Per hinge in :data:`HINGE_NAMES` order, of joints ``(..., 17, 3)``: its neutral axis and the direction its upper
    bone hangs in (the carrying body's ``-up``), each ``(..., 4, 3)``: the rest pose the carried axis swings from."""
    axes = _body_axes(joints)
    neutral, down = [], []
    for _, _, _, frame, sign in _HINGES:
        left, up = axes[frame]
        neutral.append(sign * left)
        down.append(-up)
    return torch.stack(neutral, -2), torch.stack(down, -2)


def hinge_bones(joints: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Per hinge in :data:`HINGE_NAMES` order, of joints ``(..., 17, 3)``: its unit upper and lower bone, each
    ``(..., 4, 3)``."""
    top, mid, low = (list(column) for column in zip(*HINGE_JOINTS))
    return _unit(joints[..., mid, :] - joints[..., top, :]), _unit(joints[..., low, :] - joints[..., mid, :])


def hinge_bends(joints: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
    """Per hinge in :data:`HINGE_NAMES` order, of joints ``(..., 17, 3)``: the sine of its bend along the carried
    axis (positive flexing, negative bending backwards) and the cosine between its bones, each ``(..., 4)``."""
    neutral, down = hinge_rests(joints)
    upper, lower = hinge_bones(joints)
    axis = carried_axis(neutral, down, upper)
    normal = torch.linalg.cross(upper, lower)
    sine = torch.where(overhead(down, upper), torch.linalg.vector_norm(normal, dim=-1), _dot(normal, axis))
    return sine, _dot(upper, lower)


def overhead(down: torch.Tensor, upper: torch.Tensor) -> torch.Tensor:
    """Whether unit ``upper`` bones ``(..., 3)`` point within ``OVERHEAD_DEG`` of straight up (``-down``), where the
    shortest swing from hanging, and so the carried axis, is undefined: a hinge there is read as bent forwards."""
    return _dot(down, upper) < -math.cos(math.radians(OVERHEAD_DEG))


def neck_cosine(joints: torch.Tensor) -> torch.Tensor:
    """Cosine ``(...)`` between the trunk's line (spine to thorax) and the head's (neck to head) of ``(..., 17, 3)``."""
    trunk = _unit(joints[..., J["thorax"], :] - joints[..., J["spine"], :])
    head = _unit(joints[..., J["head"], :] - joints[..., J["neck"], :])
    return _dot(trunk, head)


def limit_residuals(joints: torch.Tensor) -> torch.Tensor:
    """Per frame, the three amounts ``(..., 3)`` joints ``(..., 17, 3)`` go past their limits: each knee's backward
    bend past ``HYPEREXTENSION_MARGIN_DEG`` (as a sine; right, left) and the neck's cosine short of
    ``NECK_LIMIT_DEG``'s; zero within them."""
    sines, _ = hinge_bends(joints)
    backwards = (-sines[..., :LIMITED_HINGES] - math.sin(math.radians(HYPEREXTENSION_MARGIN_DEG))).clamp(min=0.0)
    neck = (math.cos(math.radians(NECK_LIMIT_DEG)) - neck_cosine(joints)).clamp(min=0.0)
    return torch.cat([backwards, neck[..., None]], dim=-1)


def limit_energy(joints: torch.Tensor) -> torch.Tensor:
    """Per-frame energy ``(...)`` of joints ``(..., 17, 3)``: the sum of the squared :func:`limit_residuals`."""
    return (limit_residuals(joints) ** 2).sum(-1)


def signed_flexion(joints: np.ndarray) -> np.ndarray:
    """Signed flexion ``(..., 4)`` degrees, :data:`HINGE_NAMES` order, of joints ``(..., 17, 3)``: the angle
    between each hinge's bones, negative where they bend backwards (see the module)."""
    values = torch.as_tensor(np.asarray(joints, dtype=np.float64))
    sines, cosines = hinge_bends(values)
    angle = torch.rad2deg(torch.arccos(cosines.clamp(-1.0, 1.0)))
    return torch.where(sines < 0, -angle, angle).numpy()
