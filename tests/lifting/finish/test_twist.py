"""The trunk's twist (platypose.lifting.finish.twist): a pelvis or thorax turned the other way is turned back."""

from __future__ import annotations

import numpy as np

from platypose.lifting.finish.rigid import rigid_paths
from platypose.lifting.finish.rigid_shape import body_offsets, clip_shape, rebuild
from platypose.lifting.finish.twist import PELVIS, THORAX, about_vertical, body_headings, untwisted, wrapped
from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.rotations import kabsch
from platypose.lifting.skeleton import bone_vectors
from platypose.lifting.timebase import resample


def _walk_turns(real_clips, frames: int = 60):
    """A real walk at 30 fps ``(T, 17, 3)``, its rigid shape and its bodies' rotations ``(1, T, B, 3, 3)``."""
    walk = next(m for m in real_clips if "walk" in m.name)
    motion = resample(walk.joints, walk.fps, 30.0)[:frames]
    motion = motion - motion[:, 0].mean(0) + [0.0, 0.0, 1.0]
    shape = clip_shape(motion[None])
    return motion, shape, kabsch(shape.bodies[:, None], body_offsets(motion[None]), np.ones(3))


def _twists_deg(turns: np.ndarray) -> np.ndarray:
    heading = body_headings(turns)
    return np.degrees(np.abs(wrapped(heading[..., THORAX] - heading[..., PELVIS])))


def test_a_body_turned_the_other_way_for_a_few_frames_is_turned_back(real_clips) -> None:
    """A walk's pelvis turned half a turn in frames 10-13 and its thorax 120 degrees in frames 20-21 come back to the
    walk's headings within a degree; the other frames are left exactly; a hypothesis twisted in every frame too."""
    _, _, turns = _walk_turns(real_clips)
    assert turns.shape[1] >= 30 and _twists_deg(turns).max() < 30.0  # a real walk
    damaged = np.concatenate([turns, turns])  # (2, T, B, 3, 3)
    damaged[0, 10:14, PELVIS] = about_vertical(np.full(4, np.pi)) @ turns[0, 10:14, PELVIS]
    damaged[0, 20:22, THORAX] = about_vertical(np.full(2, np.radians(120))) @ turns[0, 20:22, THORAX]
    damaged[1, :, PELVIS] = about_vertical(np.full(len(turns[0]), np.radians(150))) @ turns[0, :, PELVIS]
    assert _twists_deg(damaged[0, 10:14]).min() > 150 and _twists_deg(damaged[0, 20:22]).min() > 90
    mended = untwisted(damaged)
    off = np.degrees(np.abs(wrapped(body_headings(mended[0]) - body_headings(turns[0]))))
    assert off.max() < 1.0, off.max()
    np.testing.assert_allclose(mended[0, :10], turns[0, :10])
    np.testing.assert_allclose(mended[0, 14:20], turns[0, 14:20])
    np.testing.assert_array_equal(mended[1], damaged[1])


def test_one_view_rigid_paths_hold_the_trunk_within_its_twist(real_clips) -> None:
    """One view: a walk whose hips face backwards for four frames (the pelvis half a turn about the vertical, the
    legs hanging from it as they were) comes out of :func:`rigid_paths` with pelvis and thorax facing within
    the limit in every frame, the hips back near their true places."""
    truth, shape, turns = _walk_turns(real_clips)
    flipped = turns.copy()
    flipped[0, 20:24, PELVIS] = about_vertical(np.full(4, np.pi)) @ turns[0, 20:24, PELVIS]
    directions = bone_vectors(truth) / shape.lengths[0, :, None]
    damaged = rebuild(truth[:, 0], shape.rows(np.zeros(len(truth), int)), flipped[0], directions)
    (camera,) = ring_cameras(4)[:1]
    seen = np.ones((len(truth), 17, 1), bool)
    rigid = rigid_paths(damaged[None], shape, camera.center[None], seen, 30.0)
    after = kabsch(shape.bodies[:, None], body_offsets(rigid), np.ones(3))
    assert _twists_deg(kabsch(shape.bodies[:, None], body_offsets(damaged[None]), np.ones(3))).max() > 150
    assert _twists_deg(after).max() < 60.0
    hips = [1, 4]
    assert np.linalg.norm(rigid[0, 20:24][:, hips] - truth[20:24][:, hips], axis=-1).max() < 0.1
