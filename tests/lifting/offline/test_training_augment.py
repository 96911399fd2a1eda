"""Training augmentation on real motion: what each augmentation keeps and what it changes."""

from __future__ import annotations

import numpy as np

from platypose.lifting.offline.training import WindowSampler, prepare_clips, scale_bones
from platypose.lifting.settings import TrainConfig
from platypose.lifting.skeleton import BONES, bone_lengths
from platypose.lifting.timebase import resample


def _windows(real_clips, frames: int = 16) -> np.ndarray:
    """Two real windows ``(2, F, 17, 3)``: DeepMimic walking and the start of a holosoma climb."""
    walk = next(m for m in real_clips if "walk" in m.name)
    climb = next(m for m in real_clips if "climb" in m.name)
    return np.stack([resample(m.joints, m.fps, 30.0)[:frames] for m in (walk, climb)])


def test_bone_scaling_scales_each_bone_and_keeps_the_pelvis(real_clips):
    joints = _windows(real_clips)
    scales = np.linspace(0.85, 1.15, 17)[None].repeat(len(joints), 0)
    scaled = scale_bones(joints, scales)
    expected = bone_lengths(joints) * np.array([scales[0, c] for c, _ in BONES])
    np.testing.assert_allclose(bone_lengths(scaled), expected, rtol=1e-9)
    np.testing.assert_array_equal(scaled[:, :, 0], joints[:, :, 0])


def test_augmented_batches_start_at_the_origin_with_varied_bone_lengths(real_clips):
    clips = prepare_clips(real_clips, 30.0)
    sampler = WindowSampler(clips, 16, TrainConfig(), np.random.default_rng(0))
    batch = sampler.batch(64, 16)
    assert batch.shape == (64, 16, 17, 3) and np.isfinite(batch).all()
    np.testing.assert_allclose(batch[:, 0, 0], 0.0, atol=1e-12)  # the first frame's pelvis is the origin
    lengths = bone_lengths(batch)
    source = bone_lengths(np.concatenate([c.joints for c in clips]))
    assert 0.8 < np.median(lengths[..., 1] / np.median(source[:, 1])) < 1.2  # scaled within the configured range
    assert lengths[..., 1].std() > 0.05 * lengths[..., 1].mean()  # and actually varied


def test_windows_are_drawn_in_proportion_to_clip_length(real_clips):
    clips = prepare_clips(real_clips, 30.0)
    lengths = np.array([len(c.joints) for c in clips], dtype=float)
    sampler = WindowSampler(clips, 16, TrainConfig(), np.random.default_rng(0))
    np.testing.assert_allclose(sampler.weights, lengths / lengths.sum())
