"""Seams of a take lifted in pieces (lifting/tracks/seams.py): pieces over real frame times, hypotheses matched across
a seam, the cross-fade, the pieces joined into the take's arrays."""

import numpy as np

from platypose.lifting.tracks.seams import cross_fade, fade_weights, join_pieces, match_hypotheses, plan_pieces


def test_pieces_cover_the_take_once_with_margins(data_dir):
    """The sports2d demo's 230 frames at 30 fps in 3 s pieces: cores partition the frames at 0, 90, 180; each piece
    is lifted 1 s (30 frames) either side, clipped to the take; a piece shorter than the margin joins the one
    before."""
    from platypose.detectors.cache import read_detections

    _, _, indices = read_detections(data_dir / "video/sports2d-demo/movenet-detections.npz")
    times = indices / 30.0
    pieces = plan_pieces(times, 3.0, 1.0)
    assert [(p.core.start, p.core.stop) for p in pieces] == [(0, 90), (90, 180), (180, 230)]
    assert [(p.lifted.start, p.lifted.stop) for p in pieces] == [(0, 120), (60, 210), (150, 230)]
    assert [(p.core.start, p.core.stop) for p in plan_pieces(times, 7.2, 1.0)] == [(0, 230)]  # 0.47 s left: joined
    assert len(plan_pieces(times, 100.0, 1.0)) == 1


def test_hypotheses_are_matched_by_their_agreement(heldout_window):
    """Eight hypotheses made of a real walk at different depths; the later piece holds them shuffled and a little
    off: the matching finds each one's continuation, whatever frames are NaN."""
    rng = np.random.default_rng(0)
    earlier = np.stack([heldout_window + [0.0, 0.3 * k, 0.0] for k in range(8)])  # (8, 16, 17, 3)
    shuffle = rng.permutation(8)
    later = earlier[shuffle] + rng.normal(0, 0.02, earlier.shape)
    later[:, :5] = np.nan  # the later piece starts 5 frames into the overlap
    order = match_hypotheses(earlier, later)
    assert np.array_equal(shuffle[order], np.arange(8))
    assert np.array_equal(match_hypotheses(earlier, np.full_like(later, np.nan)), np.arange(8))


def test_cross_fade_ramps_and_keeps_what_one_side_has():
    times = np.arange(0, 4, 0.25)
    weight = fade_weights(times, 2.0, 1.0)
    assert weight[times <= 1.5].max() == 0 and weight[times >= 2.5].min() == 1 and weight[times == 2.0] == 0.5
    earlier, later = np.zeros((2, 16)), np.ones((2, 16))
    earlier[:, 10:] = np.nan  # the earlier piece has ended
    later[0, 3] = np.nan  # the later piece lacks a frame the earlier has
    joined = cross_fade(earlier, later, weight, axis=1)
    assert joined[0, 3] == 0 and np.allclose(joined[1, :6], 0) and joined[1, 8] == 0.5
    assert np.all(joined[:, 10:] == 1)
    assert np.isnan(cross_fade(np.full(3, np.nan), np.full(3, np.nan), np.ones(3), axis=0)).all()


def test_pieces_lifted_alike_join_into_the_unsplit_arrays(real_clips):
    """Two persons climbing (a real clip), 4 hypotheses each at other depths, 2 s at 30 fps cut into pieces of 0.8 s
    lifted 0.2 s either side. Each piece holds its persons' hypotheses in an order of its own (as pieces sampled
    apart would); person 1 is absent from the first 35 frames, so the first piece lifts person 0 alone. Joined: each
    person's hypotheses in the order of the first piece that lifted them, NaN where absent, the median over them."""
    from platypose.lifting.timebase import resample

    climb = next(m for m in real_clips if "climb" in m.name)
    joints = resample(climb.joints, climb.fps, 30.0)[:60].astype(np.float32)
    times = np.arange(60) / 30.0
    truth = np.stack([np.stack([joints + [0.0, 0.5 * k + p, 0.0] for k in range(4)]) for p in range(2)])
    absent = np.zeros((2, 60), bool)
    absent[1, :35] = True
    pieces = plan_pieces(times, 0.8, 0.2)
    rng = np.random.default_rng(1)
    persons = [[p for p in range(2) if not absent[p, piece.lifted].all()] for piece in pieces]
    orders = [rng.permutation(4) for _ in pieces]

    def load(n: int) -> tuple[np.ndarray, np.ndarray]:
        hypotheses = truth[persons[n]][:, orders[n], pieces[n].lifted]
        return hypotheses, np.broadcast_to(orders[n][None, :, None], hypotheses.shape[:3]).astype(np.float32)

    hypotheses = np.zeros((2, 4, 60, 17, 3), np.float32)
    median = np.zeros((2, 60, 17, 3), np.float32)
    energy = np.zeros((2, 4, 60), np.float32)
    join_pieces(pieces, persons, load, times, absent, margin=0.2, hypotheses=hypotheses, median=median, energy=energy)
    assert len(pieces) == 3 and persons[0] == [0] and persons[1] == [0, 1]
    assert np.allclose(hypotheses[0], truth[0][orders[0]], atol=1e-5)
    assert np.allclose(hypotheses[1][:, 35:], truth[1][orders[1]][:, 35:], atol=1e-5)
    assert np.isnan(hypotheses[1][:, :35]).all() and np.isnan(median[1, :35]).all()
    assert np.allclose(median[0], np.median(truth[0], axis=0), atol=1e-5)
    assert np.array_equal(energy[0], np.broadcast_to(orders[0][:, None], (4, 60)))
