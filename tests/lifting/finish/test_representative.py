"""The single answer a lift exports: the median pose around each hypothesis's own pelvis, at the median pelvis."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from platypose.lifting.finish.representative import median_motion

DATA = Path(__file__).parents[2] / "data" / "lifts"


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


def test_the_answer_of_a_real_walker_bends_its_knees_forwards():
    """The Sports2D walker seen by one uncalibrated camera (60 frames of main's 20 hypotheses, tests/data/lifts):
    over half the hypothesis-frames bend a knee backwards, the facing split between them, and the per-joint median
    of them all bends a knee backwards by more than 10 degrees in most frames. The answer, the median of the
    hypotheses that keep the limit and face one way, bends none so; its members face one side."""
    from platypose.lifting.anatomy.hinges import signed_flexion
    from platypose.lifting.finish.representative import _facings, agreeing

    hypotheses = np.load(DATA / "sports2d_walker_hypotheses.npy").astype(np.float64)
    pelvis = hypotheses[..., :1, :]
    everyone = np.median(pelvis, axis=0) + np.median(hypotheses - pelvis, axis=0)
    assert (signed_flexion(everyone)[:, :2] < -10).any(axis=1).mean() > 0.9
    answer = median_motion(hypotheses)
    assert (signed_flexion(answer)[:, :2] < -10).sum() == 0
    members = agreeing(hypotheses)
    facings = _facings(hypotheses)
    for t in range(hypotheses.shape[1]):
        chosen = facings[members[:, t], t]
        assert (chosen @ chosen.mean(axis=0)).min() > 0.0, t  # all within 90 degrees of their mean facing
    assert members.sum(axis=0).min() >= 3


def test_the_answer_stands_where_all_hypotheses_stand_whichever_agree():
    """The agreeing hypotheses change from frame to frame; the answer's pelvis is every hypothesis's median, so it
    does not jump between hypotheses metres apart in depth (one view; the real walker's hypotheses, then two of
    them pushed 3 m back, which the subset median followed in every frame it kept them)."""
    hypotheses = np.load(DATA / "sports2d_walker_hypotheses.npy").astype(np.float64)
    hypotheses[:2] += np.array([0.0, 3.0, 0.0])  # two hypotheses far behind the rest
    answer = median_motion(hypotheses)
    np.testing.assert_allclose(answer[:, 0], np.median(hypotheses[:, :, 0], axis=0), atol=1e-9)
    steps = np.linalg.norm(np.diff(answer[:, 0], axis=0), axis=-1)
    assert steps.max() < 0.1, steps.max()
