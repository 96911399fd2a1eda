"""Steady depth: a one-view person placed too near while airborne after a gap is brought back along the rays."""

from __future__ import annotations

import numpy as np
from standing_body import standing

from platypose.lifting.calibration.defaults import default_camera
from platypose.lifting.camera import project
from platypose.lifting.finish.steady_depth import smooth_path, steady_person, trusted_frames
from platypose.lifting.floor import Floor

FLOOR = Floor((0.0, 0.0, 1.0), 1.7, "given")  # the camera (at the origin, level) 1.7 m above the floor


def pelvis_path(pelvis: np.ndarray) -> tuple[float, float]:
    """Summed and largest step between consecutive present frames, and across gaps (m)."""
    seen = np.flatnonzero(np.isfinite(pelvis).all(axis=-1))
    steps = np.linalg.norm(np.diff(pelvis[seen], axis=0), axis=-1)
    return float(steps.sum()), float(steps.max())


def pelvis_depths(motion: np.ndarray, camera) -> np.ndarray:
    """Pelvis depths ``(...,)`` along ``camera``'s optical axis of joints ``(..., 17, 3)``."""
    return (np.asarray(motion, np.float64)[..., 0, :] - camera.center) @ camera.R[2]


def test_a_gap_and_a_too_near_airborne_return_are_bridged_from_where_the_person_was():
    camera = default_camera("cam", 1080, 1920)
    pose = standing(90) + [0.0, 10.0, -1.7]  # on the floor, 10 m in front of the camera
    pose[:, :, 0] += np.linspace(0.0, 1.5, 90)[:, None]  # walking across the image
    truth = pose.copy()
    truth[50:60] += [0.0, 0.0, 0.8]  # airborne after the gap
    lifted = truth.copy()
    lifted[50:60] = 0.6 * lifted[50:60]  # the sampler put the airborne frames 6 m away (the same image)
    lifted[30:50] = np.nan  # not seen for 0.7 s
    rng = np.random.default_rng(0)
    hypotheses = np.stack([lifted * s for s in (1.0, 1.03, 0.97)])[None]  # (1, 3, T, 17, 3): sizes differ
    hypotheses = (hypotheses + rng.normal(0.0, 0.002, hypotheses.shape)).astype(np.float32)
    before = hypotheses.copy()
    path_before, step_before = pelvis_path(before[0, 0, :, 0])
    seen = np.where(np.arange(90) < 30, 17, 0) + np.where(np.arange(90) >= 50, 17, 0)  # every joint where present
    moved = steady_person(hypotheses, 0, camera, 30.0, FLOOR, seen)
    after = hypotheses[0, 0, :, 0]
    path_after, step_after = pelvis_path(after)
    assert step_before > 3.0 and step_after < 1.0, (step_before, step_after)
    assert path_after < 0.5 * path_before and 3.0 < moved < 4.5
    assert np.allclose(after[50:60, 1], 10.0, atol=1.0)  # back near where the person left and lands
    assert np.allclose(after[:30, 1], before[0, 0, :30, 0, 1], atol=0.1)  # standing frames stay (within 10 cm)
    assert np.allclose(project(hypotheses, camera), project(before, camera), atol=0.05, equal_nan=True)
    assert np.all(np.isnan(hypotheses[:, :, 30:50]))  # still absent
    heights = FLOOR.height(hypotheses[0].astype(np.float64))
    assert np.nanmin(heights) >= min(np.nanmin(FLOOR.height(before[0].astype(np.float64))), 0.0) - 1e-4


def test_a_blip_of_a_few_frames_or_few_joints_is_not_trusted():
    seen = np.array([17] * 3 + [0] * 10 + [17] * 20 + [6] * 10 + [17] * 5)
    trusted = trusted_frames(seen, 30.0)
    assert not trusted[:3].any() and trusted[13:33].all() and not trusted[33:43].any() and not trusted[43:].any()


def test_smooth_path_passes_a_slow_change_and_crosses_a_gap_continuously():
    t = np.arange(120) / 30.0
    slow = 0.3 * np.sin(2 * np.pi * 0.2 * t)  # 0.2 Hz
    values = slow + np.random.default_rng(1).normal(0.0, 0.05, len(t))
    values[50:70] = np.nan
    lam = 1.0 / (2 - 2 * np.cos(2 * np.pi / 30.0)) ** 2  # 1 Hz at 30 fps
    smooth = smooth_path(values, np.ones(len(t)), lam)
    assert np.abs(smooth - slow).max() < 0.05 and np.abs(np.diff(smooth)).max() < 0.02


def test_a_variable_rate_sampling_of_a_path_gives_the_same_path():
    """Every third sample dropped (a variable-rate video): the smoothed path is the full one's at the kept times."""
    t = np.arange(90) / 30.0
    values = 0.3 * np.sin(2 * np.pi * 0.5 * t) + np.where(t > 1.5, 0.2, 0.0)  # a step the smoothing rounds off
    lam, mu = 6.85, 2.6
    full = smooth_path(values, np.full(90, 0.01), lam, mu)
    kept = np.array([i for i in range(90) if i % 3 != 1])
    sparse_path = smooth_path(values[kept], np.full(len(kept), 0.01), lam, mu, np.diff(kept).astype(float))
    uneven = smooth_path(values[kept], np.full(len(kept), 0.01), lam, mu)  # spacing ignored
    assert np.abs(sparse_path - full[kept]).max() < 0.25 * np.abs(uneven - full[kept]).max()


def test_a_person_who_drops_from_a_roof_while_unseen_lands_on_the_floor(data_dir):
    """The Sports2D man (a real lift, calibrated): on a roof 2 m up, unseen for 1.5 s while he jumps down, then on the
    floor. Carried across the gap, his depth after it stayed where the roof put it: scaled 0.62 about the camera, he
    stood 0.5 m above the floor. After the gap the floor contact decides: his stance ankles are back on the floor
    (within 5 cm of it or of their height standing on it), the roof frames keep their mean depth, the gap only bridges
    (no pelvis step over 0.5 m), images unchanged."""
    from platypose.detectors.cache import read_detections
    from platypose.detectors.keypoints import to_our_joints
    from platypose.detectors.tracking.tracker import track_detections
    from platypose.lifting.calibration import load_calibration
    from platypose.lifting.floor import CALIBRATED_FLOOR
    from platypose.lifting.stance import ANKLE_HEIGHT, standing_heights

    demo = data_dir / "video/sports2d-demo"
    camera = load_calibration(demo / "Calib_demo.toml").cameras[0]
    _, detections, indices = read_detections(demo / "movenet-detections.npz")
    tracks = track_detections([to_our_joints(p, "coco17") for p in detections], indices / 30.0, (994, 1768), "demo")
    seen = (np.nan_to_num(tracks.keypoints[:, 0, :, 2]) > 0).sum(-1)[:226]  # joints seen per frame, the man
    man = np.load(data_dir.parent / "tests/data/lifts/sports2d_demo_medians.npy")[0, :226].astype(np.float64)
    man[168:] = camera.center + 0.62 * (man[168:] - camera.center)  # held near by the placement carried over
    weights = np.linspace(0.0, 1.0, 47)[1:-1, None, None]
    man[123:168] = (1 - weights) * man[122] + weights * man[168]  # the gap, present and filled
    hypotheses = np.stack([camera.center + s * (man - camera.center) for s in (1.0, 1.04, 0.96)])[None]
    hypotheses = hypotheses.astype(np.float32)
    before = hypotheses.copy()
    steady_person(hypotheses, 0, camera, 30.0, CALIBRATED_FLOOR, seen)

    def landed(h: np.ndarray) -> np.ndarray:
        lower = np.min(h[0, :, :, [3, 6], 2], axis=0).astype(np.float64)  # (N, T) lower ankle's height
        return np.median(standing_heights(lower, 30.0)[:, 195:], axis=1)

    assert (landed(before) > ANKLE_HEIGHT + 0.4).all(), landed(before)
    assert ((landed(hypotheses) > -0.05) & (landed(hypotheses) < ANKLE_HEIGHT + 0.05)).all(), landed(hypotheses)
    roof_after, roof_before = (pelvis_depths(h[0, :, :110], camera) for h in (hypotheses, before))  # (N, 110)
    moved = np.abs(roof_after.mean(axis=1) - roof_before.mean(axis=1))
    assert (moved < 0.5).all(), moved  # the roof keeps its mean depth (the size prior's wander there smoothed)
    steps = np.linalg.norm(np.diff(hypotheses[0, :, :, 0], axis=1), axis=-1)
    assert steps.max() < 0.5, steps.max()
    assert np.allclose(project(hypotheses, camera), project(before, camera), atol=0.05)


def test_a_person_on_a_roof_keeps_one_depth_where_only_the_size_prior_placed_them(data_dir):
    """The Sports2D man on his roof (a real lift, calibrated, frames 0-122), his depth made to wander 8 % to and
    fro at 0.3 Hz as the size prior's did: standing on a raised support, whose height is his own guess, his feet
    measure no depth, so the wander goes (the depth path 5.3 -> 0.3 m; weighed as standing on the floor, 5.1 m)
    and he stays nearer his own depth; the image is unchanged."""
    from platypose.lifting.calibration import load_calibration
    from platypose.lifting.floor import CALIBRATED_FLOOR

    camera = load_calibration(data_dir / "video/sports2d-demo/Calib_demo.toml").cameras[0]
    man = np.load(data_dir.parent / "tests/data/lifts/sports2d_demo_medians.npy")[0, :123].astype(np.float64)
    wander = np.exp(0.08 * np.sin(2 * np.pi * 0.3 * np.arange(123) / 30.0))[:, None, None]
    wandered = camera.center + wander * (man - camera.center)
    hypotheses = np.stack([camera.center + s * (wandered - camera.center) for s in (1.0, 1.04, 0.96)])[None]
    hypotheses = hypotheses.astype(np.float32)
    before = hypotheses.copy()
    steady_person(hypotheses, 0, camera, 30.0, CALIBRATED_FLOOR, np.full(123, 17))
    path_before, path_after = (np.abs(np.diff(pelvis_depths(h[0, 0], camera))).sum() for h in (before, hypotheses))
    assert path_before > 5.0 and path_after < 0.1 * path_before, (path_before, path_after)
    own = pelvis_depths(man, camera)
    off_before, off_after = (np.median(np.abs(pelvis_depths(h[0, 0], camera) - own)) for h in (before, hypotheses))
    assert off_after < 0.7 * off_before, (off_before, off_after)
    assert np.allclose(project(hypotheses, camera), project(before, camera), atol=0.05)
