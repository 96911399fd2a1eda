"""How a take's views are put on one clock: ``auto``, ``none``, an offsets file or offsets by name.

Shared by ``platypose lift --sync`` / ``calib check --sync`` and ``platypose.lift(sync=...)``:

- ``none``: the calibration's ``time_offset_s`` as it is;
- ``auto``: each view's offset estimated from its 2D keypoints (:mod:`platypose.lifting.sync.offsets`),
  logged with its confidence; an estimate of low confidence, or a large one of middling confidence, is not applied
  (the calibration's offset is kept, and that is a warning); a search stopped at its bound is a warning;
- a JSON file ``{"cam01": 0.0, "cam02": 0.12}`` (or the ``offsets_s`` of a file written by ``auto``),
  or the same mapping given directly: seconds added to each view's frame times, by camera or view name.
"""

from __future__ import annotations

import json
import numbers
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from platypose.lifting.calibration.matching import match_views
from platypose.lifting.camera import MAX_TIME_OFFSET_S, Camera
from platypose.lifting.errors import InputError
from platypose.lifting.settings.choices import SyncChoice

LOW_CONFIDENCE = 0.2  # below this an estimated offset is not applied
HIGH_CONFIDENCE = 0.5  # an offset over LARGE_SHARE of the clip is applied only from this confidence up
LARGE_SHARE = 0.1  # of the shortest clip's duration
SHORT_CLIP_S = 1.5  # estimates from less motion than this can be frames off
MAX_OFFSET_S = MAX_TIME_OFFSET_S  # larger offsets are not a clock difference of one take (as in a calibration)


@dataclass(frozen=True)
class Synced:
    """The cameras on one clock, and how their offsets were obtained (``record`` for a result's meta or a file)."""

    cameras: list[Camera]
    mode: str
    confidence: list[float] | None = None

    def record(self) -> dict[str, Any]:
        """``{"mode", "offsets_s": {camera: s}}`` plus ``"confidence"`` for estimated offsets; ``--sync`` reads it back."""
        data: dict[str, Any] = {"mode": self.mode, "offsets_s": {c.name: c.time_offset_s for c in self.cameras}}
        if self.confidence is not None:
            data["confidence"] = {c.name: round(float(v), 3) for c, v in zip(self.cameras, self.confidence)}
        return data


def offsets_by_name(offsets: object, camera_names: Sequence[str], where: str) -> list[float]:
    """Offsets (s) per camera in ``camera_names`` order from a mapping keyed by camera or view name."""
    if not isinstance(offsets, Mapping) or not all(
        isinstance(v, numbers.Real) and not isinstance(v, bool) for v in offsets.values()
    ):
        raise InputError(f"{where}: expected a JSON object of camera name -> offset in seconds")
    try:
        matched = match_views(camera_names, [str(k) for k in offsets])
    except InputError as err:
        raise InputError(f"{where}: {err}") from None
    try:
        by_key = {str(k): float(v) for k, v in offsets.items()}
    except OverflowError:
        by_key = {}
    values = [by_key.get(matched[name], np.inf) for name in camera_names]
    if not all(np.isfinite(values)) or max(np.abs(values)) > MAX_OFFSET_S:
        raise InputError(f"{where}: offsets must be finite numbers of seconds, at most {MAX_OFFSET_S:g} in size")
    return values


def check_overlap(cameras: Sequence[Camera], frame_times: Sequence[np.ndarray], where: str) -> None:
    """InputError naming a view whose frames, with its offset, share no time with the first view's."""
    first = np.asarray(frame_times[0], dtype=np.float64) + cameras[0].time_offset_s
    for camera, times in zip(cameras[1:], frame_times[1:]):
        shifted = np.asarray(times, dtype=np.float64) + camera.time_offset_s
        if len(shifted) and len(first) and (shifted[-1] < first[0] or shifted[0] > first[-1]):
            raise InputError(
                f"{where}: with its offset {camera.time_offset_s:+.6g} s, view {camera.name} "
                f"({shifted[0]:.6g} to {shifted[-1]:.6g} s) shares no time with {cameras[0].name} "
                f"({first[0]:.6g} to {first[-1]:.6g} s)"
            )


def read_offsets(path: Path, camera_names: Sequence[str]) -> list[float]:
    """Offsets (s) per camera, in ``camera_names`` order, from a JSON file keyed by camera or view name."""
    return offsets_by_name(offsets_in(path), camera_names, str(path))


def offsets_in(path: Path) -> object:
    """The offsets mapping of a JSON offsets file (its ``offsets_s`` or the whole object), checked to be names to
    finite seconds; InputError naming the file otherwise."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: offsets file not found (sync takes auto, none or an offsets .json)") from None
    except (UnicodeDecodeError, json.JSONDecodeError, RecursionError) as err:
        raise InputError(f"{path}: not valid JSON ({err})") from None
    offsets = data.get("offsets_s", data) if isinstance(data, dict) else None
    names = [str(k) for k in offsets] if isinstance(offsets, Mapping) else []
    offsets_by_name(offsets, names, str(path))  # a mapping, each value a bounded number
    return offsets


def synchronise(
    choice: SyncChoice,
    keypoints: Sequence[np.ndarray],
    frame_times: Sequence[np.ndarray],
    cameras: Sequence[Camera],
    log: Callable[[str], None],
    warn: Callable[[str], None],
) -> Synced:
    """The cameras with the time offsets ``choice`` asks for; ``keypoints[c]`` (T_c, P, J, 3) on ``frame_times[c]``."""
    from platypose.lifting.sync.offsets import MIN_MOTION, estimate_offsets, main_person, with_offsets

    names = [c.name for c in cameras]
    if isinstance(choice, Mapping):
        synced = with_offsets(cameras, offsets_by_name(choice, names, "sync offsets"))
        check_overlap(synced, frame_times, "sync offsets")
        return Synced(synced, "offsets")
    if choice not in ("none", "auto") and len(cameras) < 2:
        offsets_in(Path(choice))  # one view: nothing to shift, but a broken file is still an error
    if choice == "none" or len(cameras) < 2:
        return Synced(list(cameras), "none")
    if choice != "auto":
        synced = with_offsets(cameras, read_offsets(Path(choice), names))
        check_overlap(synced, frame_times, str(choice))
        return Synced(synced, "offsets")
    persons = [main_person(k) for k in keypoints]
    estimate = estimate_offsets(persons, frame_times, cameras)
    shortest = min(float(t[-1] - t[0]) if len(t) else 0.0 for t in frame_times)
    offsets = trusted_offsets(estimate, cameras, shortest, warn)
    synced = with_offsets(cameras, offsets)
    if shortest < SHORT_CLIP_S:
        warn(
            f"sync: only {shortest:.1f} s of frames; offsets estimated from under {SHORT_CLIP_S:g} s of motion can "
            "be frames off: check them or pass an offsets .json"
        )
    rows = zip(synced, estimate.offsets_frames, estimate.confidence, estimate.at_limit, estimate.motion)
    for index, (camera, frames, confidence, at_limit, motion) in enumerate(rows):
        if motion < MIN_MOTION:
            warn(
                f"sync {camera.name}: the person barely moves in this view ({motion:.2f} heights/s); offsets "
                "cannot be estimated from its motion: check them or pass an offsets .json"
            )
        if index == 0:
            continue
        log(
            f"sync {camera.name}: estimated {frames / estimate.rate:+.3f} s ({frames:+.1f} frames) after "
            f"{synced[0].name}, confidence {confidence:.2f}; {camera.time_offset_s:+.3f} s used"
        )
        if at_limit and camera.time_offset_s == estimate.offsets_s[index]:
            warn(
                f"sync {camera.name}: the reprojection error still falls at 2 frames from the motion estimate, "
                "where the search stops: the offset or the calibration may be off by that much"
            )
    log(error_line(persons, frame_times, cameras, offsets, estimate))
    return Synced(synced, "auto", [float(v) for v in estimate.confidence])


def error_line(
    persons: Sequence[np.ndarray],
    frame_times: Sequence[np.ndarray],
    cameras: Sequence[Camera],
    offsets: Sequence[float],
    estimate: Any,
) -> str:
    """The log line of ``--sync auto``'s reprojection errors: with the calibration's offsets, with the ``offsets``
    used, and, where some of the ``estimate``'s were not applied, what they would have given (named as such)."""
    from platypose.lifting.sync.offsets import offsets_error

    recorded = offsets_error(persons, frame_times, cameras, [c.time_offset_s for c in cameras])
    used = offsets_error(persons, frame_times, cameras, offsets)
    line = f"sync: median reprojection error {recorded:.1f} px with the calibration's offsets, {used:.1f} px with those used"
    kept = [c.name for c, o, e in zip(cameras, offsets, estimate.offsets_s) if o != float(e)]
    if kept:
        line += f"; the estimates not applied ({', '.join(kept)}) would give {estimate.error_after_px:.1f} px"
    return line


def trusted_offsets(
    estimate: Any, cameras: Sequence[Camera], shortest_s: float, warn: Callable[[str], None]
) -> list[float]:
    """Each camera's offset: the estimate (:class:`platypose.lifting.sync.offsets.SyncEstimate`) where it can be trusted,
    else the calibration's (said once per camera): an estimate under ``LOW_CONFIDENCE`` is not applied, nor one
    moving a view by more than ``LARGE_SHARE`` of the shortest clip (``shortest_s``) under ``HIGH_CONFIDENCE``."""
    offsets = [float(v) for v in estimate.offsets_s]
    for c in range(1, len(cameras)):
        recorded, confidence = cameras[c].time_offset_s, float(estimate.confidence[c])
        shift = abs(offsets[c] - recorded)
        if confidence < LOW_CONFIDENCE:
            reason = f"its confidence {confidence:.2f} is under {LOW_CONFIDENCE:g}"
        elif shift > LARGE_SHARE * shortest_s and confidence < HIGH_CONFIDENCE:
            reason = (
                f"it moves the view by {shift:.3f} s, over {LARGE_SHARE:.0%} of the {shortest_s:.1f} s clip, "
                f"which needs confidence {HIGH_CONFIDENCE:g} (got {confidence:.2f})"
            )
        else:
            continue
        warn(
            f"sync {cameras[c].name}: the estimated offset {offsets[c]:+.3f} s ({offsets[c] * estimate.rate:+.1f} "
            f"frames) is not applied: {reason}; the calibration's {recorded:+.3f} s is kept (check it, or pass an "
            "offsets .json)"
        )
        offsets[c] = recorded
    return offsets
