"""How a window continuing the one before is placed across a detection gap (lifting/sampling/placement.py)."""

import torch

from platypose.lifting.sampling.placement import continuation_ramp


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
