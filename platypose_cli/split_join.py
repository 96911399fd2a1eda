"""The driver's side of ``platypose lift --split-seconds S``: one take's detection and lifting spread over piece tasks
(:mod:`platypose.cli.split_pieces`) and joined into the arrays of one unsplit result.

- **Detection** (:func:`detect_in_pieces`): the video is cut into stretches of S seconds, each detected by a task; the
  driver joins the detections (a few kB per frame) into the video's detection cache, the file an unsplit run
  writes, and the usual reader tracks them over the whole take. Tracking, ID repair, the persons choice and the gap
  rule therefore see the whole take: the same 2D, track ids and persons as an unsplit run.
- **Lifting** (:class:`SplitLifter`, in place of :func:`platypose.lifting.tracks.persons.lift_persons`): the take's 2D is cut
  into pieces of S seconds lifted with a margin either side (:func:`platypose.lifting.tracks.seams.plan_pieces`), each
  piece's persons present lifted by a task; the driver then reads the pieces in order (one piece in memory at a
  time), reorders each piece's hypotheses to continue the piece before and cross-fades them at the seam
  (:mod:`platypose.lifting.tracks.seams`), and writes them into the caller's arrays. Rigid people, the floor, the
  representative answer, plausibility flags and export then run on the whole take as in an unsplit run.
"""

from __future__ import annotations

import hashlib
import json
import os
import pickle
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from platypose.cli.piece_files import read_lift_piece
from platypose.cli.piece_plan import PiecePlan
from platypose.cli.split_pieces import detect_piece, lift_piece, make_piece_folder, piece_folder
from platypose.lifting.tracks.seams import cross_fade, fade_weights, match_hypotheses, plan_pieces

MIN_MARGIN_S = 1.0  # seconds each piece is lifted past its own frames, at least (and at least --max-gap)


def margin_seconds(max_gap: float) -> float:
    """Seconds a piece is lifted either side of its own frames: every gap the lift bridges then lies within one
    piece, and neighbours share twice this around their seam."""
    return max(MIN_MARGIN_S, float(max_gap))


def _digest(*parts) -> str:
    """A short digest of picklable ``parts`` (arrays by their bytes)."""
    h = hashlib.sha256()
    for part in parts:
        h.update(part.tobytes() if isinstance(part, np.ndarray) else pickle.dumps(part))
    return h.hexdigest()[:24]


def split_hooks(pool, settings, name: str, log, read: Callable) -> tuple[SplitLifter, Callable]:
    """For job ``name`` lifted with ``settings`` (RunSettings with ``split_seconds``) over ``pool``: the lifter
    :func:`platypose.pipeline.run_take` takes, and ``read`` (a view reader) preceded, for a video, by its detection
    in pieces into the detection cache ``read`` then finds (keypoint files are read whole)."""
    from platypose.detectors.sources.keypoint_source import is_keypoint_source

    folder = settings.out / name
    lifter = SplitLifter(pool, settings.prior, settings.split_seconds, piece_folder(settings.out, name), log)

    def split_read(source: Path):
        if not is_keypoint_source(source):
            detect_in_pieces(source, settings.detect, folder, settings.split_seconds, pool, log)
        return read(source)

    return lifter, split_read


def detect_in_pieces(source: Path, detect, folder: Path, split_s: float, pool, log) -> int:
    """Detect ``source`` (a video) in pieces of ``split_s`` seconds run by ``pool`` and write the joined detections
    as its detection cache in ``folder`` (nothing to do when that cache is current); pieces already detected by an
    earlier run (``folder/.pieces``) are not detected again, and a damaged cache or piece is removed, warned of
    (``log``, a JobLog) and detected again. The number of pieces detected now."""
    from platypose.cli.detection import cached_detector
    from platypose.detectors.cache import DetectionCache, cache_key, read_detections
    from platypose.detectors.sources.video import video_info
    from platypose.media import frame_stamps

    name = cached_detector(detect).name
    key = cache_key(source, name, detect.stride, detect.max_frames)
    cache = DetectionCache(folder, source.stem)
    if cache.load(key, log.warning) is not None:
        return 0
    info = video_info(source)
    stamps = frame_stamps(source)[0]
    step = max(int(round(split_s * info.fps / detect.stride)), 1) * detect.stride  # a multiple of the stride
    starts = list(range(0, max(len(stamps), 1), step))
    pieces = piece_folder(folder.parent, folder.name)
    make_piece_folder(pieces)
    plan = PiecePlan(pieces)
    tasks, paths, todo = [], [], []
    for n, start in enumerate(starts):
        count = None if n == len(starts) - 1 else step  # the last piece reads to the end, whatever the header says
        piece_key = json.dumps({"video": key, "start": start, "count": count})
        path = pieces / f"{source.stem}.{_digest(piece_key)}.detections.npz"
        paths.append(path)
        if os.path.lexists(path) and (why := plan.why_not(path)) is not None:
            log.warning(f"damaged split piece {source.name}:{n}: {path}: {why}; removed, detected again")
            path.unlink(missing_ok=True)
            plan.forget(path)
        if DetectionCache(path.parent, path.name.removesuffix(".detections.npz")).load(piece_key, log.warning) is None:
            stamp = int(stamps[start]) if start < len(stamps) else None
            tasks.append((detect_piece, (str(source), detect, start, stamp, count, str(path), piece_key)))
            todo.append(n)
    started = time.perf_counter()
    seconds = pool.run(tasks, [f"{source.name}:{n}" for n in todo], lambda i: plan.record(paths[todo[i]]), say=log)
    if tasks:
        log(
            f"{source}: {len(tasks)} piece(s) of {split_s:g} s detected {piece_times(seconds, time.perf_counter() - started)}"
        )
    detections, indices = [], []
    for path in paths:
        _, found, at = read_detections(path)
        detections += found
        indices.append(at)
    cache.save(key, detections, np.concatenate(indices) if indices else np.zeros(0, np.int64))
    return len(tasks)


class SplitLifter:
    """:func:`platypose.lifting.tracks.persons.lift_persons` spread over pieces of ``split_s`` seconds run by ``pool``, the
    pieces cached in ``folder`` (a piece lifted by an earlier run with the same inputs, whose digest the plan of
    pieces holds, is read back); ``prior`` (PriorSettings) is what the workers load. ``log`` (a JobLog) gets one
    line per call, and a warning for each damaged piece (removed and lifted again)."""

    def __init__(self, pool, prior, split_s: float, folder: Path, log) -> None:
        self.pool, self.prior, self.split_s, self.folder, self.log = pool, prior, split_s, folder, log

    def __call__(
        self, prior, keypoints, times, cameras, roots, absent, config, windows, hypotheses, median, energy,
        progress=None,
    ) -> None:  # fmt: skip
        """As ``lift_persons``: ``keypoints`` (C, T, P, 17, 3) lifted into ``hypotheses`` (P, N, T, 17, 3), ``median``
        (P, T, 17, 3) and ``energy`` (P, N, T), NaN where ``absent`` (P, T)."""
        margin = margin_seconds(windows.max_gap)
        pieces = plan_pieces(times, self.split_s, margin)
        make_piece_folder(self.folder)
        plan = PiecePlan(self.folder)

        def task(n: int) -> tuple[list[int], Path, tuple]:
            """Piece n's persons present, its file, and the task that lifts it."""
            t = pieces[n].lifted
            who = [p for p in range(absent.shape[0]) if not absent[p, t].all()]
            inputs = {
                "keypoints": np.ascontiguousarray(keypoints[:, t][:, :, who]),
                "times": np.asarray(times[t]),
                "cameras": list(cameras),
                "roots": [None if roots[p] is None else np.asarray(roots[p][t]) for p in who],
                "absent": np.ascontiguousarray(absent[who][:, t]),
                "config": config,
                "windows": windows,
            }
            key = _digest(prior.checksum, self.prior, *(inputs[k] for k in ("keypoints", "times", "absent")),
                          inputs["roots"], inputs["cameras"], config, windows)  # fmt: skip
            path = self.folder / f"lift.{key}.npz"
            return who, path, (lift_piece, (self.prior, inputs, str(path)))

        def name(n: int) -> str:
            return f"{n} (frames {pieces[n].lifted.start}-{pieces[n].lifted.stop - 1})"

        tasks, todo, paths, persons = [], [], [], []
        for n in range(len(pieces)):
            who, path, work = task(n)
            paths.append(path)
            persons.append(who)
            if who and os.path.lexists(path) and (why := plan.why_not(path)) is not None:
                self._drop(plan, path, f"piece {name(n)}: {path}: {why}")
            if who and not os.path.lexists(path):
                tasks.append(work)
                todo.append(n)
        P = absent.shape[0]
        earlier = sum(1 for who in persons if who) - len(tasks)
        self.log(
            f"lifting in {len(pieces)} piece(s) of {self.split_s:g} s (+{margin:g} s either side), "
            f"{earlier} done earlier"
        )
        done = [0]

        def each(i: int) -> None:
            plan.record(paths[todo[i]])
            done[0] += 1
            if progress is not None:
                progress(list(range(P)), done[0], len(tasks))

        started = time.perf_counter()
        seconds = self.pool.run(tasks, [name(n) for n in todo], each, say=self.log)
        if tasks:
            self.log(f"{len(tasks)} piece(s) lifted {piece_times(seconds, time.perf_counter() - started)}")

        def load(n: int) -> tuple[np.ndarray, np.ndarray]:
            """Piece n's arrays, checked; a piece that fails the checks is removed and lifted once more."""
            who, path = persons[n], paths[n]
            if not who:
                return np.zeros((0, 0, 0, 17, 3), np.float32), np.zeros((0, 0, 0), np.float32)
            present = ~absent[who][:, pieces[n].lifted]
            try:
                return read_lift_piece(path, present, config.samples)
            except ValueError as err:
                self._drop(plan, path, f"piece {name(n)}: {path}: {err}")
            self.pool.run([task(n)[2]], [name(n)], lambda i: plan.record(path), say=self.log)
            return read_lift_piece(path, present, config.samples)

        join_pieces(pieces, persons, load, times, absent, margin, hypotheses, median, energy)

    def _drop(self, plan: PiecePlan, path: Path, why: str) -> None:
        """Remove a damaged piece file and its line in the plan, warning ``why``."""
        self.log.warning(f"damaged split {why}; removed, lifted again")
        path.unlink(missing_ok=True)
        plan.forget(path)


def piece_times(seconds: Sequence[float | None], wall: float) -> str:
    """How long pieces took: the wall time of them all, and each on its worker (median, largest)."""
    each = np.array([s for s in seconds or [] if s is not None])
    told = f", each {np.median(each):.1f} s median, {each.max():.1f} s at most on its worker" if len(each) else ""
    return f"in {wall:.1f} s{told}"


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


def join_pieces(pieces, persons, load, times, absent, margin, hypotheses, median, energy) -> None:
    """Write the pieces' results (``load(n)``: piece n's hypotheses and energy; persons ``persons``) into the take's
    arrays in frame order: each
    piece's hypotheses reordered to continue the piece before (over the frames both lifted), cross-faded around
    each seam (:func:`platypose.lifting.tracks.seams.fade_weights`), NaN where ``absent``; one piece (and the one
    before) in memory at a time."""
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
