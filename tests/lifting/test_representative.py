"""The single answer a lift exports: the median pose around each hypothesis's own pelvis, at the median pelvis."""

from __future__ import annotations

import numpy as np

from platypose.lifting.representative import median_motion


def test_where_a_hypothesis_stands_does_not_smear_the_pose():
    """Three poses at three depths: the answer is their per-joint median pose, at the median pelvis. The
    coordinate-wise median of the absolute joints mixes one hypothesis's depth with another's pose."""
    rng = np.random.default_rng(0)
    poses = rng.normal(0.0, 0.3, (3, 2, 17, 3))
    poses[:, :, 0] = 0.0
    depths = np.array([10.0, 0.0, 5.0])[:, None, None, None] * np.array([0.0, 1.0, 0.0])
    hypotheses = poses + depths
    answer = median_motion(hypotheses)
    np.testing.assert_allclose(answer - answer[:, :1], np.median(poses, axis=0), atol=1e-12)
    np.testing.assert_allclose(answer[:, 0], np.broadcast_to([0.0, 5.0, 0.0], (2, 3)), atol=1e-12)
    coordinate_wise = np.median(hypotheses, axis=0)
    assert np.abs((coordinate_wise - coordinate_wise[:, :1]) - np.median(poses, axis=0)).max() > 0.1


def test_a_frame_without_hypotheses_stays_absent():
    hypotheses = np.zeros((4, 3, 17, 3))
    hypotheses[:, 1] = np.nan
    answer = median_motion(hypotheses)
    assert np.isnan(answer[1]).all() and np.isfinite(answer[[0, 2]]).all()
