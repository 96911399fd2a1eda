"""Where the sampler places a window (lifting/sampling/placement.py): depth limits in front of the camera, each
hypothesis's own size, and how a window continuing the one before is placed across a detection gap."""

import numpy as np
import torch

from platypose.lifting.offline.camera_rigs import ring_cameras
from platypose.lifting.sampling.placement import (
    DEPTH_RANGE,
    LANDING_RAMP,
    Anchor,
    continuation_ramp,
    continued_offset,
    limit_depth,
    reappearing,
    typical_size,
)
from platypose.lifting.skeleton import SIZE_BONES, TYPICAL_BONE_LENGTHS, bone_lengths


def _rows(seen_rows: list[list[int]], frames: int = 12, held: int = 2) -> tuple[torch.Tensor, torch.Tensor]:
    mask = torch.zeros(len(seen_rows), frames)
    mask[:, :held] = 1
    seen = torch.zeros(len(seen_rows), frames)
    for row, on in enumerate(seen_rows):
        seen[row, on] = 1
    return mask, seen


def test_without_a_gap_the_ramp_runs_to_the_windows_end():
    mask, seen = _rows([list(range(12))])
    ramp = continuation_ramp(mask, seen)
    torch.testing.assert_close(ramp, continuation_ramp(mask))
    torch.testing.assert_close(ramp[0], torch.tensor([1.0, 1.0, *[(11 - f) / 10 for f in range(2, 12)]]))


def test_across_a_gap_the_rays_place_the_track_from_the_gaps_start():
    """Seen on frames 2-3, unseen on 4-8, seen again from 9 (the walker's window with a cut): the carried
    placement gives way to the rays' by the gap's start, so their smoothed placement runs from where the track was
    seen to where it is seen again (carried on instead, the walker fell 0.3-0.4 m behind in the gap and jumped)."""
    mask, seen = _rows([[0, 1, 2, 3, 9, 10, 11]])
    ramp = continuation_ramp(mask, seen)[0]
    torch.testing.assert_close(ramp[:5], torch.tensor([1.0, 1.0, 2 / 3, 1 / 3, 0.0]))
    assert (ramp[4:] == 0).all()


def test_a_gap_right_after_the_anchor_is_carried_until_the_person_is_seen_again():
    """The rays' placement there has only the frames after the gap (extrapolated back from them, a one-view lift
    of the Sports2D man stepped 13 m): the carried placement holds to the first seen frame, then ramps out."""
    mask, seen = _rows([[0, 1, 7, 8, 9, 10, 11]])
    ramp = continuation_ramp(mask, seen)[0]
    torch.testing.assert_close(ramp, torch.tensor([1.0] * 7 + [0.8, 0.6, 0.4, 0.2, 0.0]))


def test_a_gap_right_after_the_anchor_with_enough_seen_after_it_is_placed_by_the_rays_across_it():
    """Seen again for longer than the gap lasts in the window: the rays' placement is extrapolated back no farther
    than its data spans, and takes the track across the gap (carried, the Sports2D man stepped 0.59 m on landing)."""
    mask, seen = _rows([[0, 1, *range(5, 12)]])
    ramp = continuation_ramp(mask, seen)[0]
    torch.testing.assert_close(ramp, torch.tensor([1.0, 1.0, 0.75, 0.5, 0.25, *[0.0] * 7]))


def test_a_window_inside_a_gap_carries_the_track_on():
    mask, seen = _rows([[0, 1], []])
    assert (continuation_ramp(mask, seen) == 1).all()


def test_a_person_reappears_in_a_window_only_after_a_gap_that_began_before_it():
    """The floor contact places the windows a person comes back in after a gap (the Sports2D man, carried across his
    1.5 s gap, stood 0.6 m above the floor): back after 5 unseen frames right after the anchor; not after 1 (a
    missed detection); not when seen before the gap in the window (its rays place it across); not when never back."""
    mask, seen = _rows([[0, 1, *range(7, 12)], [0, 1, *range(3, 12)], [0, 1, 2, 3, 9, 10, 11], [0, 1]])
    assert reappearing(mask, seen, min_gap=3).tolist() == [True, False, False, False]
    assert not reappearing(mask, None).any()


def test_depth_limit_keeps_every_root_in_front_and_near_the_others():
    """One view: roots too far, too near, beside or behind the camera come back within DEPTH_RANGE of the median
    depth, and never far sideways (a root just behind the camera was once thrown kilometres away)."""
    cam = ring_cameras(4)[0]
    R, t = torch.tensor(cam.R), torch.tensor(cam.t)
    rng = np.random.default_rng(3)
    in_camera = np.concatenate(
        [
            rng.normal([0, 0, 4], [0.3, 0.3, 0.5], (8, 3)),
            [[0.2, 0.1, 30.0], [0.3, 0.0, 2.0], [1.5, 0.2, 0.001], [0.4, -0.2, -0.4], [0.0, 0.0, -6.0]],
        ]
    )
    world = torch.tensor((in_camera - cam.t) @ cam.R)[None, :, None]  # (B=1, N=13, F=1, 3)
    limited = limit_depth(world, R, t)[0, :, 0].numpy() @ cam.R.T + cam.t  # back in camera axes
    median = np.median(in_camera[:, 2])
    assert np.all(limited[:, 2] >= median / DEPTH_RANGE - 1e-6) and np.all(limited[:, 2] <= median * DEPTH_RANGE + 1e-6)
    assert np.allclose(limited[:8], in_camera[:8])  # within range: untouched
    assert np.allclose(limited[8] / limited[8, 2], in_camera[8] / in_camera[8, 2])  # too far: along its own ray
    assert np.allclose(limited[9] / limited[9, 2], in_camera[9] / in_camera[9, 2])  # too near: along its own ray
    assert np.all(np.linalg.norm(limited[:, :2], axis=-1) < 0.5 * median)  # beside / behind: onto the median ray


def test_size_prior_scales_each_hypothesis_to_its_own_factor(heldout_window):
    poses = torch.tensor(np.stack([heldout_window, 1.3 * heldout_window]))[None]  # (B=1, N=2, F, 17, 3)
    factors = torch.tensor([0.9, 1.1], dtype=torch.float64)
    typical = sum(TYPICAL_BONE_LENGTHS[b] for b in SIZE_BONES)
    sized = typical_size(poses, factors)[0].numpy()
    size = np.median(bone_lengths(sized)[..., list(SIZE_BONES)].sum(-1), axis=-1)
    assert np.allclose(size, typical * factors.numpy(), rtol=1e-5)
    assert np.allclose(sized[:, :, 0], poses[0, :, :, 0].numpy())  # scaled about the pelvis
    same = typical_size(poses)[0].numpy()  # no factors: one scale for the window keeps relative sizes
    ratio = bone_lengths(same[1]).sum(-1) / bone_lengths(same[0]).sum(-1)
    assert np.allclose(ratio, 1.3)


def test_a_window_the_floor_contact_places_bridges_the_gap_to_where_the_person_is_seen_again():
    """After a gap right after the anchor (frames 2-14 unseen, seen from 15): the carried placement gives way
    linearly to the rays' placement at the first frame seen, and the gap's frames take the rays' placement there,
    not their own (extrapolated back over the gap from one view, it moved the Sports2D man's hypotheses 8-16 m in
    his gap). A window the person is seen in throughout leaves the carried placement within ``LANDING_RAMP`` frames."""
    mask, seen = _rows([[0, 1, *range(15, 24)], list(range(24))], frames=24)
    anchor = Anchor(torch.zeros(2, 1, 24, 17, 3), mask, seen=seen, landing=torch.tensor([True, True]))
    frames = torch.arange(24.0)
    offset = frames[None, None, :, None].expand(2, 1, 24, 3)  # the rays' placement: the frame's number
    placed = continued_offset(offset, torch.zeros(2, 1, 24, 17, 3), anchor)[:, 0, :, 0]
    bridge = torch.where(frames < 15, 15 * ((frames - 1) / 14).clamp(min=0), frames)
    torch.testing.assert_close(placed[0], bridge)
    short = ((1 + LANDING_RAMP - frames) / LANDING_RAMP).clamp(0, 1)
    torch.testing.assert_close(placed[1], (1 - short) * torch.where(frames < 2, 2.0, frames))


def test_a_window_that_ends_in_a_gap_goes_on_from_where_the_person_was_last_seen():
    """Seen on frames 2-6 after the anchor, unseen from 7 to the window's end, on a floor: those frames take the rays'
    placement of frame 6 (the prior's motion goes on from there), not the rays' own extrapolated over the gap."""
    mask, seen = _rows([[0, 1, 2, 3, 4, 5, 6]])
    anchor = Anchor(torch.zeros(1, 1, 12, 17, 3), mask, seen=seen, landing=torch.tensor([False]))  # a floor
    frames = torch.arange(12.0)
    offset = frames[None, None, :, None].expand(1, 1, 12, 3)  # the rays' placement: the frame's number
    placed = continued_offset(offset, torch.zeros(1, 1, 12, 17, 3), anchor)[0, 0, :, 0]
    ramp = continuation_ramp(mask, seen)[0]
    torch.testing.assert_close(placed, (1 - ramp) * frames.clamp(max=6.0))
