"""Lifting whole tracks: resample to the prior's rate, sample windows in batches, stitch, resample back.

Input is 2D keypoints of P persons seen by C calibrated cameras on one clock;
output is N hypotheses per person at the input's frame times, each one
continuous motion across windows (see :mod:`lifting.tracks.windows`). Each person is
lifted only over the spans where it is present, so the cost follows the
person-frames present, not persons x clip length; windows of persons present at
the same time, and their hypotheses, go through the network as one batch.
Results stream out (:func:`lift_stream`) as soon as no later window changes
them, so memory does not grow with the track's length.
"""

from __future__ import annotations

from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass

import numpy as np
import torch

from platypose.lifting.camera import Camera
from platypose.lifting.prior.model import PriorBundle
from platypose.lifting.sampling.placement import Anchor, landing
from platypose.lifting.sampling.sampler import SampleResult, cameras_and_rays, sample
from platypose.lifting.settings import SamplerConfig, WindowSettings
from platypose.lifting.timebase import blend_samples, interpolate, interpolation_weights, resample_keypoints_at
from platypose.lifting.tracks.roots import presence, seen_frames
from platypose.lifting.tracks.windows import WindowKeys, WindowPlan, blend_weights, continuation_anchor, plan_windows

CHUNK_FRAMES = 1024  # input frames per chunk at most: a long stretch nobody is in does not fill memory


@dataclass(frozen=True)
class LiftOutput:
    """``hypotheses`` (P, N, T, 17, 3) world metres and per-frame reprojection ``energy`` (P, N, T)."""

    hypotheses: np.ndarray
    energy: np.ndarray


@dataclass(frozen=True)
class LiftChunk:
    """Final frames ``start .. start + t`` of every person: ``hypotheses`` (P, N, t, 17, 3), ``energy`` (P, N, t)."""

    start: int
    hypotheses: np.ndarray
    energy: np.ndarray


def prior_clock(frame_times: np.ndarray, fps: float) -> np.ndarray:
    """Times at the prior's rate spanning ``frame_times``, ``(T',)``."""
    start, end = float(frame_times[0]), float(frame_times[-1])
    return start + np.arange(int(np.floor((end - start) * fps + 1e-6)) + 1) / fps


def lift_stream(
    prior: PriorBundle,
    cameras: Sequence[Camera],
    keypoints: np.ndarray,
    frame_times: np.ndarray,
    sampler: SamplerConfig,
    windows: WindowSettings = WindowSettings(),
    *,
    root_trajectory: np.ndarray | None = None,
    progress: Callable[[int, int], None] | None = None,
    present: np.ndarray | None = None,
    identities: Sequence[int] | None = None,
) -> Iterator[LiftChunk]:
    """Lift P persons' keypoints ``(C, T, P, 17, 3)`` seen by ``cameras`` at ``frame_times`` ``(T,)``, in chunks.

    Each person is lifted only over the spans where it is present (:func:`person_spans`),
    each span in windows of its own that continue one another; frames where a person is
    absent are NaN and never sampled. Windows of different persons that start at about the
    same time go through the network together (:func:`next_round`). Chunks come in frame
    order as soon as no later window can change their frames, so memory holds a few windows
    whatever the length. ``root_trajectory`` (P, T, 3), if known, fixes each person's pelvis
    path. ``progress(done, total)`` counts windows (over all persons). ``present`` ``(P, T)``: where each person is
    present, as the caller computed it (:func:`platypose.lifting.tracks.roots.presence` under ``windows.max_gap``);
    None: computed here.
    """
    frame_times = np.asarray(frame_times, dtype=np.float64)
    clock = prior_clock(frame_times, prior.fps)
    length = min(windows.window, prior.config.max_frames)
    overlap = min(windows.overlap, length // 2)
    spans = person_spans(keypoints, frame_times, clock, length, overlap, windows.max_gap, present=present)
    per_window = KeypointWindows(keypoints, frame_times, clock)
    roots = None
    if root_trajectory is not None:
        roots = np.moveaxis(interpolate(np.moveaxis(root_trajectory, 1, 0), frame_times, clock), 1, 0)  # (P, T', 3)
    total = sum(span.plan.count for span in spans)
    keys = WindowKeys(sampler.seed, range(keypoints.shape[2]) if identities is None else identities, clock, prior.fps)
    runner = _WindowRunner(
        prior, list(cameras), per_window, roots, sampler, windows, keys, progress=progress, total=total
    )
    stitchers = [StreamingStitch(s.plan, clock[s.first : s.first + s.plan.total], frame_times[s.frames]) for s in spans]
    gather = _PersonFrames(keypoints.shape[2], sampler.samples, len(frame_times), spans)
    done = [0] * len(spans)  # windows sampled per span
    previous: list[np.ndarray | None] = [None] * len(spans)  # each span's last window, (1, N, F, 17, 3)
    while True:
        batch = next_round(spans, done, length - overlap)
        if not batch:
            break
        items = [(s, int(done[s]), continuation_anchor(previous[s], spans[s].plan) if done[s] else None) for s in batch]
        for (s, w, _), result in zip(items, runner.run(spans, items)):
            previous[s] = np.asarray(result.fitted, dtype=np.float32)
            joints = np.asarray(result.joints, dtype=np.float32)[0]  # (N, F, 17, 3)
            window = (np.moveaxis(joints, 1, 0), np.moveaxis(np.asarray(result.energy, dtype=np.float32)[0], 1, 0))
            for start, (hypotheses, frame_energy) in stitchers[s].add(w, window):
                gather.add(s, spans[s].frames.start + start, np.moveaxis(hypotheses, 0, 1), frame_energy.T)
            done[s] = w + 1
        frontier = [spans[s].frames.start + stitchers[s].emitted for s in range(len(spans))]
        yield from gather.emit(frontier, done)
    yield from gather.emit([len(frame_times)] * len(spans), [s.plan.count for s in spans])


@dataclass(frozen=True)
class Span:
    """Person ``person`` present over the input frames ``frames``, lifted on the prior's frames from ``first`` on
    in the windows of ``plan`` (its starts count from ``first``)."""

    person: int
    frames: slice
    first: int
    plan: WindowPlan

    def start(self, w: int) -> int:
        """Prior frame where window ``w`` starts."""
        return self.first + int(self.plan.starts[w])


def person_spans(
    keypoints: np.ndarray,
    frame_times: np.ndarray,
    clock: np.ndarray,
    length: int,
    overlap: int,
    max_gap: float = WindowSettings.max_gap,
    *,
    present: np.ndarray | None = None,
) -> list[Span]:
    """The spans where each person of keypoints ``(C, T, P, 17, 3)`` is present (:func:`lifting.tracks.roots.presence`:
    seen, or unseen for at most ``max_gap`` seconds between seen frames), person by person in time order, each
    planned in windows of ``length`` prior frames sharing ``overlap``.

    A span covers the prior frames from the last one at or before its first input frame to the first one at or
    after its last, so every input frame of the span lies between two of them. ``present`` ``(P, T)``: the presence
    the caller computed from the same keypoints, times and ``max_gap`` (None: computed here).
    """
    present = presence(keypoints, frame_times, max_gap) if present is None else present  # (P, T)
    spans = []
    for person in range(present.shape[0]):
        edges = np.diff(np.concatenate([[0], present[person].astype(np.int8), [0]]))
        for begin, end in zip(np.nonzero(edges == 1)[0], np.nonzero(edges == -1)[0]):
            first = max(int(np.searchsorted(clock, frame_times[begin], side="right")) - 1, 0)
            last = min(int(np.searchsorted(clock, frame_times[end - 1], side="left")), len(clock) - 1)
            plan = plan_windows(last - first + 1, length, overlap)
            spans.append(Span(person, slice(int(begin), int(end)), first, plan))
    return spans


def next_round(spans: Sequence[Span], done: Sequence[int], stride: int) -> list[int]:
    """Spans whose next window is sampled now: those starting within ``stride`` prior frames of the earliest next
    window of any span (``done[s]`` windows of span ``s`` are sampled). Persons present together go through the
    network together and every span moves on at the same pace, so few windows wait to be stitched."""
    waiting = [s for s, span in enumerate(spans) if done[s] < span.plan.count]
    if not waiting:
        return []
    earliest = min(spans[s].start(done[s]) for s in waiting)
    return [s for s in waiting if spans[s].start(done[s]) < earliest + max(stride, 1)]


def lift_tracks(
    prior: PriorBundle,
    cameras: Sequence[Camera],
    keypoints: np.ndarray,
    frame_times: np.ndarray,
    sampler: SamplerConfig,
    windows: WindowSettings = WindowSettings(),
    *,
    root_trajectory: np.ndarray | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> LiftOutput:
    """:func:`lift_stream` gathered into whole arrays (for short inputs and tests)."""
    chunks = list(
        lift_stream(
            prior, cameras, keypoints, frame_times, sampler, windows, root_trajectory=root_trajectory, progress=progress
        )
    )
    return LiftOutput(
        hypotheses=np.concatenate([c.hypotheses for c in chunks], axis=2),
        energy=np.concatenate([c.energy for c in chunks], axis=2),
    )


class KeypointWindows:
    """Keypoints ``(C, P, F, 17, 3)`` of some persons over F prior frames, resampled when a window is asked for.

    The same numbers as resampling the whole track with :func:`platypose.lifting.timebase.resample_keypoints` and
    cutting it into windows (NaN past the end), without a resampled copy of a long track.
    """

    def __init__(self, keypoints: np.ndarray, frame_times: np.ndarray, clock: np.ndarray) -> None:
        frames = np.moveaxis(keypoints, 1, 0)  # (T, C, P, 17, 3)
        if len(frame_times) == 1:  # as resample_keypoints: every prior frame takes the one sample
            frames = np.concatenate([frames, frames])
            self.idx, self.w = np.zeros(len(clock), np.intp), np.zeros(len(clock))
        else:
            self.idx, self.w = interpolation_weights(frame_times, clock)
        self.frames = frames

    def window(self, start: int, length: int, persons: Sequence[int], stop: int | None = None) -> np.ndarray:
        """Prior frames ``start .. start + length`` of ``persons``, ``(C, len(persons), length, 17, 3)``; frames from
        ``stop`` on (and past the clock's end) are missing (NaN, confidence 0)."""
        idx, weight = self.idx[start : start + length], self.w[start : start + length]
        first = int(idx[0])
        frames = self.frames[first : int(idx[-1]) + 2][:, :, list(persons)]
        window = _pad(resample_keypoints_at(frames, idx - first, weight), length)  # (F, C, P, 17, 3)
        if stop is not None and stop - start < length:
            window[max(stop - start, 0) :, ..., :2] = np.nan
            window[max(stop - start, 0) :, ..., 2] = 0.0
        return np.moveaxis(window, 0, 2)


def _pad(frames: np.ndarray, length: int) -> np.ndarray:
    """``frames`` (t, ...) padded with NaN to ``length`` frames, as :func:`lifting.tracks.windows.cut` pads the last window."""
    if len(frames) >= length:
        return frames
    return np.concatenate([frames, np.full((length - len(frames), *frames.shape[1:]), np.nan, frames.dtype)])


class StreamingStitch:
    """:func:`lifting.tracks.windows.stitch` then :func:`lifting.timebase.interpolate` onto the input's frame times, streamed.

    Windows are added in order, each a tuple of arrays ``(F, ...)`` (frames first). After
    window w, every prior frame before window w+1 starts is final: those frames are
    resampled to the frame times they cover and handed out. The numbers are those of
    the whole-array path (same float64 sums in the same order, same interpolation).
    """

    def __init__(self, plan: WindowPlan, clock: np.ndarray, frame_times: np.ndarray) -> None:
        self.plan, self.clock, self.frame_times = plan, clock, frame_times
        self.weights = blend_weights(plan)
        self.single = len(clock) == 1
        self.idx, self.w = (None, None) if self.single else interpolation_weights(clock, frame_times)
        self.base = 0  # prior frame of self.sums[0]
        self.sums: list[np.ndarray] | None = None  # per field: float64 (frames, ...) from self.base on
        self.emitted = 0  # input frames handed out so far

    def add(self, w: int, window: tuple[np.ndarray, ...]) -> Iterator[tuple[int, tuple[np.ndarray, ...]]]:
        """Add window ``w`` (fields ``(F, ...)``); yield ``(first input frame, fields (t, ...) float32)`` now final."""
        start, F = int(self.plan.starts[w]), self.plan.length
        weight = self.weights[w]
        if self.sums is None:
            self.sums = [np.zeros((0, *v.shape[1:]), dtype=np.float64) for v in window]
        grow = start + F - (self.base + len(self.sums[0]))
        if grow > 0:
            self.sums = [np.concatenate([s, np.zeros((grow, *s.shape[1:]))]) for s in self.sums]
        for s, value in zip(self.sums, window):
            s[start - self.base : start - self.base + F] += weight.reshape((F,) + (1,) * (value.ndim - 1)) * value
        last = w == self.plan.count - 1
        final = self.plan.total if last else int(self.plan.starts[w + 1])  # prior frames < final are done
        chunk = self._resample(final, last)
        if chunk is not None:
            yield chunk

    def _resample(self, final: int, last: bool) -> tuple[int, tuple[np.ndarray, ...]] | None:
        """Input frames whose two neighbouring prior frames are below ``final`` (all that are left if ``last``)."""
        first, T = self.emitted, len(self.frame_times)
        if self.single:
            stop = T if last else first
        else:
            stop = T if last else first + int(np.searchsorted(self.idx[first:] + 1, final, side="left"))
        if stop <= first:
            return None
        if self.single:
            fields = tuple(np.repeat(s[:1], stop - first, axis=0) for s in self.sums)
        else:
            idx = self.idx[first:stop] - self.base
            fields = tuple(blend_samples(s, idx, self.w[first:stop]) for s in self.sums)
        self.emitted = stop
        if stop < T and not self.single:
            # prior frames no later input frame needs, and no later window adds to: at a low input rate the next
            # input frame can lie past the next window's start
            drop = min(int(self.idx[stop]), final) - self.base
            self.sums = [s[drop:] for s in self.sums]
            self.base += drop
        return first, tuple(f.astype(np.float32) for f in fields)


class _WindowRunner:
    """Samples a round of windows (one per span), those of equal length and continuation state in one batch."""

    def __init__(self, prior, cameras, per_window, roots, sampler, windows, keys, *, progress, total: int) -> None:
        self.prior, self.cameras, self.per_window, self.roots = prior, cameras, per_window, roots
        self.sampler, self.windows, self.keys, self.progress, self.total = sampler, windows, keys, progress, total
        self.done = 0

    def run(self, spans: Sequence[Span], items: list) -> list[SampleResult]:
        """Results (batch of one) of ``items`` = (span index, window, anchor or None) in their order; an anchor is
        (joints (1, N, F, 17, 3), mask (F,)) continuing the span's previous window."""
        results: list[SampleResult | None] = [None] * len(items)
        groups: dict[tuple[int, bool, int | None], list[int]] = {}
        keypoints = [self._keypoints(spans[s], w) for s, w, _ in items]
        for i, (s, _, anchor) in enumerate(items):
            key = (spans[s].plan.length, anchor is not None, only_viewer(keypoints[i]))
            groups.setdefault(key, []).append(i)
        for (_, _, viewer), members in groups.items():
            kp = np.concatenate([keypoints[i] for i in members], axis=1)  # (C, B, F, 17, 3)
            windows = [(spans[items[i][0]], items[i][1], items[i][2]) for i in members]
            batch = self._sample(windows, kp, viewer)
            for b, i in enumerate(members):
                results[i] = SampleResult(batch.joints[b : b + 1], batch.energy[b : b + 1], batch.fitted[b : b + 1])
            self.done += len(members)
            if self.progress is not None:
                self.progress(self.done, self.total)
        return results

    def _keypoints(self, span: Span, w: int) -> np.ndarray:
        """Keypoints ``(C, 1, F, 17, 3)`` of window ``w`` of ``span``."""
        return self.per_window.window(span.start(w), span.plan.length, [span.person], span.first + span.plan.total)

    def _sample(self, windows: list, kp: np.ndarray, viewer: int | None) -> SampleResult:
        """Hypotheses of windows (span, window, anchor) of one length, all anchored or none, as one batch, from their
        keypoints ``kp`` ``(C, B, F, 17, 3)``; windows that camera ``viewer`` alone sees are lifted as one view."""
        F = windows[0][0].plan.length
        cameras = self.cameras if viewer is None else [self.cameras[viewer]]
        kp = kp if viewer is None else kp[viewer : viewer + 1]
        obs, rays = cameras_and_rays(cameras, kp[..., :2], kp[..., 2], device=self.prior.device)
        dtype, device = obs.keypoints.dtype, obs.keypoints.device
        root = None
        if self.roots is not None:
            path = np.stack(
                [_pad(self.roots[span.person, span.start(w) : span.start(w) + F], F) for span, w, _ in windows]
            )
            root = torch.as_tensor(path, dtype=dtype, device=device)
        held = None
        if windows[0][2] is not None:
            joints = torch.as_tensor(np.concatenate([a[0] for _, _, a in windows]), dtype=dtype, device=device)
            mask = torch.as_tensor(np.stack([a[1] for _, _, a in windows]), dtype=dtype, device=device)
            seen = torch.as_tensor(seen_frames(kp, 1).T, dtype=dtype, device=device)  # (B, F): frames with keypoints
            before = np.concatenate([seen_frames(self._keypoints(s, w - 1), 1).T * (w > 1) for s, w, _ in windows])
            before = torch.as_tensor(before, dtype=dtype, device=device)  # the same in the windows before them
            held = Anchor(joints, mask, self.windows.anchor_weight, seen, landing(mask, seen, before))
        keys = [self.keys.key(span.person, span.start(w)) for span, w, _ in windows]
        rays = None if root is not None else rays
        return sample(self.prior, obs, rays, self.sampler, F, root_trajectory=root, anchor=held, window_keys=keys)


def only_viewer(keypoints: np.ndarray) -> int | None:
    """The one camera seeing a window of keypoints ``(C, B, F, 17, 3)`` when no other sees it (and there are several),
    else None: the sampler's one-view steps (:mod:`lifting.sampling.views`) are then that window's, among any cameras."""
    seeing = np.flatnonzero((np.nan_to_num(keypoints[..., 2]) > 0).reshape(len(keypoints), -1).any(-1))
    return int(seeing[0]) if len(keypoints) > 1 and len(seeing) == 1 else None


class _PersonFrames:
    """Gathers every span's final frames into chunks of all persons over the input frames, NaN where absent."""

    def __init__(self, persons: int, samples: int, frames: int, spans: Sequence[Span]) -> None:
        self.persons, self.samples, self.frames, self.spans = persons, samples, frames, spans
        self.pieces: list[tuple[int, int, np.ndarray, np.ndarray]] = []  # (person, first frame, (N, t, 17, 3), (N, t))
        self.emitted = 0

    def add(self, s: int, start: int, hypotheses: np.ndarray, energy: np.ndarray) -> None:
        """Final frames ``start ..`` of span ``s``: ``hypotheses`` (N, t, 17, 3), ``energy`` (N, t)."""
        self.pieces.append((self.spans[s].person, start, hypotheses, energy))

    def emit(self, frontier: Sequence[int], done: Sequence[int]) -> Iterator[LiftChunk]:
        """Chunks of the frames every person has final, at most ``CHUNK_FRAMES`` each: span ``s`` is final up to
        input frame ``frontier[s]``, or wholly once ``done[s]`` covers its windows; frames before a span that has
        not begun are final (absent)."""
        stop = self.frames
        for s, span in enumerate(self.spans):
            if done[s] < span.plan.count:
                stop = min(stop, max(frontier[s], span.frames.start) if done[s] else span.frames.start)
        while self.emitted < stop:
            yield self._chunk(self.emitted, min(stop, self.emitted + CHUNK_FRAMES))

    def _chunk(self, first: int, stop: int) -> LiftChunk:
        """Frames ``first .. stop`` of every person (NaN where absent); the pieces keep only later frames."""
        hypotheses = np.full((self.persons, self.samples, stop - first, 17, 3), np.nan, np.float32)
        energy = np.full((self.persons, self.samples, stop - first), np.nan, np.float32)
        kept = []
        for person, start, h, e in self.pieces:
            a, b = max(start, first), min(start + h.shape[1], stop)
            if b > a:
                hypotheses[person, :, a - first : b - first] = h[:, a - start : b - start]
                energy[person, :, a - first : b - first] = e[:, a - start : b - start]
            if start + h.shape[1] > stop:
                cut = max(stop - start, 0)
                kept.append((person, start + cut, h[:, cut:], e[:, cut:]))
        self.pieces, self.emitted = kept, stop
        return LiftChunk(first, hypotheses, energy)
