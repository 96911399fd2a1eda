"""Metrics against values computed by hand on small arrays."""

import numpy as np
import pytest
from scipy.spatial.transform import Rotation

from platypose.lifting.offline import metrics


def _truth(frames: int = 2) -> np.ndarray:
    rng = np.random.default_rng(0)
    truth = rng.normal(0, 0.3, (frames, 17, 3))
    truth[:, 0] = 0.0
    return truth


def test_min_mpjpe_picks_best_hypothesis_per_frame_and_mpspe_per_sequence():
    truth = _truth()
    a = truth.copy()
    b = truth.copy()
    a[0, 1:] += [0.01, 0, 0]  # frame 0: every non-root joint 10 mm off
    a[1, 1:] += [0.05, 0, 0]  # frame 1: 50 mm off
    b[0, 1:] += [0.03, 0, 0]  # frame 0: 30 mm
    b[1, 1:] += [0.02, 0, 0]  # frame 1: 20 mm
    hyps = np.stack([a, b])
    # per frame mean over 17 joints (root error 0): 10*16/17, 50*16/17 / 30*16/17, 20*16/17
    scale = 16 / 17
    assert metrics.min_mpjpe(hyps, truth) == pytest.approx((0.010 + 0.020) / 2 * scale)
    assert metrics.min_mpspe(hyps, truth) == pytest.approx(min(0.030, 0.025) * scale)
    assert metrics.best_sequence(hyps, truth) == 1


def test_root_relative_metrics_ignore_translation_and_root_error_does_not():
    truth = _truth()
    moved = truth + [1.0, 2.0, 0.5]
    assert metrics.min_mpjpe(moved[None], truth) == pytest.approx(0.0)
    assert metrics.root_error(moved[None], truth) == pytest.approx(np.sqrt(1 + 4 + 0.25))


def test_procrustes_metrics_remove_rotation_and_scale():
    truth = _truth(3)
    rot = Rotation.from_euler("xyz", [10, -20, 30], degrees=True).as_matrix()
    similar = 1.3 * truth @ rot.T + 0.2
    assert metrics.pa_mpjpe(similar[None], truth) == pytest.approx(0.0, abs=1e-9)
    assert metrics.pa_mpspe(similar[None], truth) == pytest.approx(0.0, abs=1e-9)
    assert metrics.min_mpjpe(similar[None], truth) > 0.05


def test_mpjve_is_velocity_error_of_best_sequence():
    truth = _truth(3)
    hyp = truth.copy()
    hyp[2, 1:] += [0.0, 0.004, 0.003]  # last frame: 5 mm jump on 16 joints
    # velocities differ only between frames 1 and 2: 5 mm on 16 of 17 joints, averaged over 2 steps
    assert metrics.mpjve(hyp[None], truth) == pytest.approx(0.005 * 16 / 17 / 2)
    assert metrics.mpjve(hyp[None, :1], truth[:1]) == 0.0


def test_ece_is_low_for_calibrated_and_high_for_overconfident_hypotheses():
    rng = np.random.default_rng(1)
    truth = _truth(50)
    calibrated = truth[None] + rng.normal(0, 0.05, (400, 50, 17, 3))
    # the truth is a draw from the same spread: shift the hypotheses by one more draw
    calibrated = calibrated + rng.normal(0, 0.05, (1, 50, 17, 3))
    calibrated[:, :, 0] = calibrated[:, :, 0] * 0
    overconfident = truth[None] + 0.05 + rng.normal(0, 0.001, (400, 50, 17, 3))
    assert metrics.ece(calibrated, truth) < 0.05
    assert metrics.ece(overconfident, truth) > 0.4


def test_ece_by_hand_on_two_hypotheses():
    truth = np.zeros((1, 2, 3))
    truth[0, 1] = [0.0, 0.0, 1.0]
    hyps = np.zeros((3, 1, 2, 3))
    hyps[:, 0, 1] = [[0, 0, 0.9], [0, 0, 1.2], [0, 0, 1.0]]  # median 1.0: spreads 0.1, 0.2, 0; truth gap 0
    # the q-quantile of the spreads (0, 0.1, 0.2) exceeds the gap 0 for every q > 0: freq = 0 at q = 0, else 1;
    # ECE = mean over the 21 quantiles of |freq - q| = sum_{k=1..20} (1 - k/20) / 21 = 9.5 / 21
    assert metrics.ece(hyps, truth) == pytest.approx(9.5 / 21)


def test_ece_pools_windows_whose_frames_share_one_error():
    """One-view ambiguity moves a whole window: hypotheses and truth are draws of one depth offset per window.

    Such a sampler is calibrated; each single window is not (all its frames rank the truth alike), so
    per-window ECEs are large while the frequencies pooled over windows give a small ECE.
    """
    rng = np.random.default_rng(3)
    base = _truth(8)
    direction = rng.normal(size=(1, 17, 3)) * 0.1
    direction[:, 0] = 0
    pooled, per_window = [], []
    for _ in range(300):
        hyps = base[None] + rng.normal(size=(100, 1, 1, 1)) * direction[None]
        truth = base + rng.normal() * direction
        pooled.append(metrics.calibration_frequencies(hyps, truth))
        per_window.append(metrics.ece(hyps, truth))
    assert metrics.ece_from_frequencies(np.mean(pooled, axis=0)) < 0.05
    assert np.mean(per_window) > 0.2


def test_worst_clip_ece_shows_opposite_errors_that_pooling_hides():
    """Clip 0's hypotheses are too tight (truth drawn 3x wider), clip 1's too wide (truth 3x tighter)."""
    from platypose.lifting.offline.evaluation import score_windows

    rng = np.random.default_rng(5)
    base = _truth(4)
    hyps, truths, clips = [], [], []
    for clip, truth_scale in ((0, 3.0), (1, 1 / 3)):
        for _ in range(60):
            offsets = rng.normal(0, 0.02, (100, 1, 17, 3))
            offsets[..., 0, :] = 0
            truth_offset = rng.normal(0, 0.02 * truth_scale, (1, 17, 3))
            truth_offset[..., 0, :] = 0
            hyps.append(base + offsets)
            truths.append(base + truth_offset)
            clips.append(clip)
    answers = np.median(np.stack(hyps), axis=1)
    values = score_windows(np.stack(hyps), np.stack(truths), np.array(clips), answers)
    each = [
        score_windows(
            np.stack(hyps[i : i + 60]), np.stack(truths[i : i + 60]), np.zeros(60, dtype=int), answers[i : i + 60]
        )
        for i in (0, 60)
    ]
    assert all(e["ECE worst"] == e["ECE"] for e in each)  # one clip: nothing to hide
    assert values["ECE worst"] == pytest.approx(max(e["ECE"] for e in each))
    assert min(e["ECE"] for e in each) > 0.25  # both clips are badly calibrated
    assert values["ECE"] < 0.6 * min(e["ECE"] for e in each)  # and the pool looks much better than either


def test_answer_errors_score_one_motion_hip_centred_and_aligned():
    """A pose shifted as a whole is exact hip-centred; a rotated and scaled copy is exact after alignment."""
    truth = _truth(5)
    shifted = truth + np.array([0.3, -2.0, 0.1])
    assert metrics.answer_mpjpe(shifted, truth) == pytest.approx(0.0, abs=1e-12)
    turn = np.array([[0.0, -1.0, 0.0], [1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])
    turned = 1.1 * truth @ turn.T
    assert metrics.answer_mpjpe(turned, truth) > 0.05
    assert metrics.answer_pa_mpjpe(turned, truth) == pytest.approx(0.0, abs=1e-9)
    bent = truth.copy()
    bent[:, 3] += np.array([0.0, 0.1, 0.0])  # one joint 10 cm off: 10/17 cm on average
    assert metrics.answer_mpjpe(bent, truth) == pytest.approx(0.1 / 17)
