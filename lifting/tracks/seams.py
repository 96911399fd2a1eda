"""Joining the lifts of a take's time pieces at their seams: pieces planned over the frame times, each piece's
hypotheses matched to the piece before by their agreement in the frames both lifted, and a cross-fade over the
middle of that overlap.

A take of T frames is cut into pieces of ``split_s`` seconds (their cores); each piece is lifted over its core and
``margin_s`` either side, so two neighbours share ``2 * margin_s`` seconds around their seam. Hypothesis k of one
piece and hypothesis k of the next are sampled independently, so before joining, the later piece's hypotheses are
reordered (Hungarian method on the mean joint distance over the shared frames) to continue the earlier piece's; then
the later piece's weight ramps from 0 to 1 over the middle ``margin_s`` seconds of the overlap (the outer halves are
each piece's edge, lifted without the context past it). :func:`join_pieces` writes the pieces so joined into the
take's arrays. No file is read or written.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np
from scipy.optimize import linear_sum_assignment


@dataclass(frozen=True)
class Piece:
    """Frames ``core`` of a take are this piece's own; it is lifted over ``lifted`` (its core and a margin)."""

    core: slice
    lifted: slice


def plan_pieces(times: np.ndarray, split_s: float, margin_s: float) -> list[Piece]:
    """Pieces of ``split_s`` seconds over frame times ``times`` (T,), each lifted ``margin_s`` either side of its core;
    a last piece shorter than ``margin_s`` joins the one before (one piece when the take is short)."""
    times = np.asarray(times, dtype=np.float64)
    start = times[0]
    bounds = [0]
    while True:
        nxt = int(np.searchsorted(times, start + len(bounds) * split_s, side="left"))
        if nxt >= len(times) or times[-1] - times[nxt] < margin_s:
            break
        bounds.append(nxt)
    bounds.append(len(times))
    pieces = []
    for a, b in zip(bounds[:-1], bounds[1:]):
        first = int(np.searchsorted(times, times[a] - margin_s, side="left"))
        last = int(np.searchsorted(times, times[b - 1] + margin_s, side="right"))
        pieces.append(Piece(slice(a, b), slice(first, last)))
    return pieces


def match_hypotheses(earlier: np.ndarray, later: np.ndarray) -> np.ndarray:
    """The order (N,) of ``later``'s hypotheses that continues ``earlier``'s: ``later[order][k]`` goes with
    ``earlier[k]``; both (N, t, 17, 3) over the same frames, NaN where not lifted. Hungarian method on the mean joint
    distance over the frames both have; the identity when they share none."""
    both = np.isfinite(earlier).all(axis=(0, 2, 3)) & np.isfinite(later).all(axis=(0, 2, 3))  # (t,)
    if not both.any():
        return np.arange(len(later))
    a, b = earlier[:, both].astype(np.float64), later[:, both].astype(np.float64)
    cost = np.linalg.norm(a[:, None] - b[None], axis=-1).mean(axis=(2, 3))  # (N earlier, N later)
    rows, cols = linear_sum_assignment(cost)
    order = np.empty(len(later), dtype=np.intp)
    order[rows] = cols
    return order


def fade_weights(times: np.ndarray, seam_s: float, margin_s: float) -> np.ndarray:
    """The later piece's weight (t,) at frame times ``times``: 0 before ``seam_s - margin_s / 2``, 1 after
    ``seam_s + margin_s / 2``, linear between."""
    if margin_s <= 0:
        return (np.asarray(times) >= seam_s).astype(np.float64)
    return np.clip((np.asarray(times, dtype=np.float64) - seam_s) / margin_s + 0.5, 0.0, 1.0)


def cross_fade(earlier: np.ndarray, later: np.ndarray, weight: np.ndarray, axis: int) -> np.ndarray:
    """``earlier`` and ``later`` (the same shape, frames along ``axis``) blended with the later one's ``weight`` (t,)
    per frame; where one is NaN the other is taken whole (NaN where both are)."""
    shape = [1] * earlier.ndim
    shape[axis] = -1
    w = np.broadcast_to(np.reshape(weight, shape), earlier.shape)
    have_a, have_b = np.isfinite(earlier), np.isfinite(later)
    w = np.where(have_a & have_b, w, np.where(have_b, 1.0, 0.0))
    blended = (1 - w) * np.nan_to_num(earlier) + w * np.nan_to_num(later)
    return np.where(have_a | have_b, blended, np.nan).astype(earlier.dtype)


def _over(frames: slice, piece_lifted: slice, who, h, e, P: int, N: int) -> tuple[np.ndarray, np.ndarray]:
    """A piece's hypotheses (P, N, t, 17, 3) and energy (P, N, t) over the take's ``frames``, NaN where it has none."""
    t = frames.stop - frames.start
    hyp = np.full((P, N, t, 17, 3), np.nan, np.float32)
    en = np.full((P, N, t), np.nan, np.float32)
    a, b = max(frames.start, piece_lifted.start), min(frames.stop, piece_lifted.stop)
    if b > a and who:
        hyp[who, :, a - frames.start : b - frames.start] = h[:, :, a - piece_lifted.start : b - piece_lifted.start]
        en[who, :, a - frames.start : b - frames.start] = e[:, :, a - piece_lifted.start : b - piece_lifted.start]
    return hyp, en


def join_pieces(
    pieces: Sequence[Piece],
    persons: Sequence[list[int]],
    load: Callable[[int], tuple[np.ndarray, np.ndarray]],
    times: np.ndarray,
    absent: np.ndarray,
    *,
    margin: float,
    hypotheses: np.ndarray,
    median: np.ndarray,
    energy: np.ndarray,
) -> None:
    """Write the pieces' results into the take's ``hypotheses`` (P, N, T, 17, 3), ``median`` (P, T, 17, 3) and
    ``energy`` (P, N, T) in frame order: ``load(n)`` gives piece n's hypotheses (p, N, t, 17, 3) and energy (p, N, t)
    of its persons ``persons[n]`` over the frames it lifted (``margin`` seconds either side of its core). Each
    piece's hypotheses are reordered to continue the piece before (over the frames both lifted) and cross-faded
    around each seam (:func:`fade_weights`), NaN where ``absent`` (P, T); one piece (and the one before) in memory at
    a time."""
    P, N = absent.shape[0], hypotheses.shape[1]
    times = np.asarray(times, dtype=np.float64)
    previous = None  # (piece, persons, hypotheses, energy) of the piece before, reordered
    written = 0
    for n, piece in enumerate(pieces):
        h, e = load(n)
        h, e = np.array(h), np.array(e)
        if previous is not None:
            before, who_before, hb, eb = previous
            shared = slice(piece.lifted.start, before.lifted.stop)
            for p in set(persons[n]) & set(who_before):
                i, j = who_before.index(p), persons[n].index(p)
                a = hb[i][:, shared.start - before.lifted.start : shared.stop - before.lifted.start]
                b = h[j][:, shared.start - piece.lifted.start : shared.stop - piece.lifted.start]
                order = match_hypotheses(a, b)
                h[j], e[j] = h[j][order], e[j][order]
        if n + 1 < len(pieces):
            seam_next = times[pieces[n + 1].core.start]
            stop = int(np.searchsorted(times, seam_next - margin / 2, side="left"))
        else:
            stop = len(times)
        frames = slice(written, stop)
        hyp, en = _over(frames, piece.lifted, persons[n], h, e, P, N)
        if previous is not None:
            before, who_before, hb, eb = previous
            weight = fade_weights(times[frames], times[piece.core.start], margin)
            hyp_b, en_b = _over(frames, before.lifted, who_before, hb, eb, P, N)
            hyp = cross_fade(hyp_b, hyp, weight, axis=2)
            en = cross_fade(en_b, en, weight, axis=2)
        gone = absent[:, frames]
        hyp[np.broadcast_to(gone[:, None], hyp.shape[:3])] = np.nan
        en[np.broadcast_to(gone[:, None], en.shape)] = np.nan
        hypotheses[:, :, frames] = hyp
        energy[:, :, frames] = en
        median[:, frames] = np.median(hyp, axis=1)
        written = stop
        previous = (piece, persons[n], h, e)
