"""The floor's quick lift reads a long take in a few stretches (lifting/tracks/quick_floor.py)."""

from __future__ import annotations

import numpy as np
from demo_tracks import demo_take

from platypose.lifting.tracks import quick_floor as quick_module
from platypose.lifting.tracks.quick_floor import FLOOR_PASS_SECONDS, floor_frames


def test_a_short_take_is_read_whole_and_a_long_one_in_spread_stretches():
    short = np.arange(0, 120.0, 1 / 30)
    assert np.array_equal(floor_frames(short), np.arange(len(short)))
    match = 12.5 + np.arange(0, 90 * 60.0, 1 / 25)  # 90 minutes at 25 fps
    frames = floor_frames(match)
    read = match[frames]
    assert abs(len(frames) / 25 - FLOOR_PASS_SECONDS) < 1.0  # two minutes of it
    pieces = np.split(read, np.flatnonzero(np.diff(read) > 1) + 1)
    assert len(pieces) == 6 and all(abs(p[-1] - p[0] - 20.0) < 0.1 for p in pieces)
    centres = [float(np.mean(p)) - 12.5 for p in pieces]
    assert np.allclose(centres, (np.arange(6) + 0.5) * 900.0, atol=0.1)  # spread over the match


def test_the_quick_lift_of_a_long_take_costs_what_two_minutes_cost(tiny_prior, monkeypatch):
    """A take longer than the quick lift reads (the limit made 12 s here, to keep the test quick; 120 s in use): a
    7.7 s take of two people repeated three times is read for 12 s, in 6 stretches, and the floor is still found
    under their standing ankles."""
    from platypose.lifting.job_log import JobLog
    from platypose.lifting.settings import SamplerConfig, WindowSettings

    take = demo_take(SamplerConfig(samples=2, seed=0), WindowSettings(max_gap=1.0), repeats=3)
    lifted = []
    original = quick_module.lift_persons

    def spy(**arguments):
        lifted.append(arguments["take"].times)
        return original(**arguments)

    monkeypatch.setattr(quick_module, "lift_persons", spy)
    monkeypatch.setattr(quick_module, "FLOOR_PASS_SECONDS", 12.0)
    log = JobLog()
    floor = quick_module.quick_floor(tiny_prior, take, log=log)
    assert len(lifted) == 1 and abs(len(lifted[0]) / 30.0 - 12.0) < 0.5
    assert floor is not None and floor.found["stance_points"] > 10
    assert "over 12 s of the take in 6 stretches" in log.lines[-1]
