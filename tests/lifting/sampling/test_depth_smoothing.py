"""One view: every joint's depth path is smoothed along its ray (lifting.depth_smoothing)."""

import numpy as np
import pytest
import torch

from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.sampling.depth_smoothing import smooth_depth
from platypose.lifting.timebase import resample


def _in_camera(window: np.ndarray) -> torch.Tensor:
    """A window ``(F, 17, 3)`` in the first ring camera's frame, component-first ``(3, 1, 1, F, 17)``."""
    cam = ring_cameras(4)[0]
    points = (window - window[:, 0].mean(0) + [0.0, 0.0, 1.0]) @ cam.R.T + cam.t
    return torch.as_tensor(points, dtype=torch.float64).permute(2, 0, 1)[:, None, None]


@pytest.fixture(scope="module")
def windows(real_clips) -> dict[str, torch.Tensor]:
    """Real climbing (64 frames at 30 fps) and real walking (its 39 frames), seen from the first ring camera."""
    climb = next(m for m in real_clips if "climb" in m.name)
    walk = next(m for m in real_clips if "walk" in m.name)
    return {m.name: _in_camera(resample(m.joints, m.fps, 30.0)[:64]) for m in (climb, walk)}


def _projection(points: torch.Tensor) -> torch.Tensor:
    return points[:2] / points[2:]


def _depth_steps(points: torch.Tensor) -> torch.Tensor:
    return (points[2, 0, 0, 1:] - points[2, 0, 0, :-1]).abs()  # (F-1, 17)


def test_a_depth_switch_is_spread_over_frames_and_the_image_does_not_move(windows):
    """The upper body switching 0.3 m in depth between two frames, as the M prior's hypotheses did."""
    for truth in windows.values():
        switched, middle = truth.clone(), truth.shape[3] // 2
        depth = switched[2, ..., middle:, 7:]  # spine and above, from the middle frame on
        switched[:, ..., middle:, 7:] *= (depth + 0.3) / depth  # slid back along their rays
        smoothed = smooth_depth(switched, smoothness=10.0)
        assert (_projection(smoothed) - _projection(switched)).abs().max() < 1e-9  # every joint stays on its ray
        assert _depth_steps(smoothed).max() < 0.05 + _depth_steps(truth).max(), _depth_steps(
            smoothed
        ).max()  # 0.3 m before
        # depth the switch adds, smoothed against given; away from it (12 frames and more) the two agree
        left = ((smoothed[2] - smooth_depth(truth, smoothness=10.0)[2]) - (switched[2] - truth[2]))[0, 0]  # (F, 17)
        away = torch.cat([left[: middle - 12], left[middle + 12 :]])
        assert away.abs().max() < 0.01, left.abs().amax(dim=1)


def test_real_motion_passes_within_a_few_centimetres(windows):
    """Measured: climbing moves 0.4 mm on average (at most 7 mm), walking towards the camera 2.8 mm (at most 36 mm,
    a foot as it strikes the ground)."""
    for name, truth in windows.items():
        change = (smooth_depth(truth, smoothness=10.0) - truth).norm(dim=0)
        assert change.mean() < 0.005 and change.max() < 0.05, (name, change.mean(), change.max())  # metres


def test_anchored_frames_keep_their_depth_and_off_or_short_windows_are_untouched(windows):
    truth = next(iter(windows.values()))
    moved = truth.clone()
    moved[:, ..., 2:, :] *= (moved[2, ..., 2:, :] + 0.5) / moved[2, ..., 2:, :]  # right after the anchored frames
    anchored = torch.zeros(1, truth.shape[3])
    anchored[:, :2] = 1
    smoothed = smooth_depth(moved, 10.0, anchored)
    assert (smoothed[:, :, :, :2] - moved[:, :, :, :2]).norm(dim=0).max() < 1e-3
    assert (smoothed[:, :, :, 2:] - moved[:, :, :, 2:]).norm(dim=0).max() > 0.1  # the rest does move
    assert (smooth_depth(moved, 0.0) == moved).all()
    assert (smooth_depth(moved[:, :, :, :2], 10.0) == moved[:, :, :, :2]).all()


def test_a_path_through_the_camera_plane_is_left_alone(windows):
    truth = next(iter(windows.values())).clone()
    truth[2, ..., 3, 0] = -0.2  # the pelvis behind the camera in one frame: no usable ray
    smoothed = smooth_depth(truth, 10.0)
    assert torch.isfinite(smoothed).all()
    assert (smoothed[:, ..., 0] == truth[:, ..., 0]).all()
