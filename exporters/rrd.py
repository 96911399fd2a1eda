"""The rerun recording of one input: video, cameras, 2D keypoints, every hypothesis, median, spread, energy.

Entity paths (all under a Z-up ``world``):

- ``world/cameras/<cam>``: camera pose and pinhole; ``.../video``: the video;
  ``.../keypoints/p<id>``: 2D keypoints of person ``<id>`` (confidence > 0).
- ``world/people/p<id>``: the person's annotation classes, in the person's own
  hue: ``.../hypotheses``: every hypothesis as a skeleton (class id =
  hypothesis index, muted shades of the hue); ``.../median``: the median
  skeleton (class id N, the bright hue) and ``.../median/bones``: its bones as
  thick lines; ``.../spread``: a wireframe sphere per joint at the median,
  radius = RMS distance of the hypotheses to the median; ``.../label``: the
  person's name above the head (with "check" when a quality flag is raised).
- ``plots/energy/p<id>``: energy over hypotheses (5%, median, 95%) per frame;
  ``plots/spread/p<id>``: mean per-joint spread in millimetres, one plot each.
- ``quality``: a Markdown summary per person (frames, spread, BVH fit, flags) and the warnings.
- ``world/floor`` and ``world/people/p<id>/plausibility``: the floor (given or estimated) and each person's
  plausibility report, from the lift's meta (:mod:`exporters.rrd_floor`).

Videos are shown on both timelines: a video frame is put on the ``frame``
timeline at the output frame whose time it has (within half a frame), and its
clock stamp is that frame's exact stamp.
"""

from __future__ import annotations

import colorsys
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

import platypose.exporters.rerun_adapter as rra
from platypose.exporters.frames import frame_chunks
from platypose.exporters.result import LiftResult
from platypose.exporters.rrd_floor import log_estimated_camera, log_floor_and_plausibility, log_who
from platypose.exporters.video import check_video_size, jpeg_frames, needs_reencode, reencode_h264
from platypose.exporters.video_clock import video_stamps
from platypose.exporters.watched_writer import run_watched
from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import atomic_path
from platypose.lifting.skeleton import BONES, JOINT_NAMES, NUM_JOINTS

VIDEO_MODES = ("asset", "frames", "none")
KEYPOINTS_CLASS = 0
ENERGY_SHADES = (0.55, 1.0, 0.55)  # value of the 5 %, median and 95 % lines in the person's hue
LABEL_HEIGHT_M = 0.25  # the name floats this far above the head
PRIOR_LABEL = "(unseen: filled by the prior)"  # appended to the label on frames lifted through a detection gap
# The camera views share a region of about this aspect (width / height) beside the 3D view.
CAMERA_REGION = (800.0, 700.0)


def _rgba(hue: float, saturation: float, value: float) -> tuple[int, int, int, int]:
    return tuple(int(round(255 * c)) for c in colorsys.hsv_to_rgb(hue % 1.0, saturation, value)) + (255,)


def person_hue(slot: int) -> float:
    """Hue of the ``slot``-th person: golden-ratio steps from orange, so neighbours differ clearly."""
    return 0.08 + 0.618034 * slot


def person_colour(slot: int) -> tuple[int, int, int, int]:
    """The bright colour of a person (median, bones, label, 2D keypoints, plots)."""
    return _rgba(person_hue(slot), 0.85, 1.0)


def hypothesis_colours(slot: int, count: int) -> list[tuple[int, int, int, int]]:
    """Muted shades of the person's hue for ``count`` hypotheses, so the median stands out."""
    values = np.linspace(0.55, 0.8, count) if count > 1 else [0.7]
    return [_rgba(person_hue(slot), 0.45, v) for v in values]


def camera_grid_columns(sizes_hw: list[tuple[int, int]], region: tuple[float, float] = CAMERA_REGION) -> int:
    """Columns of the camera grid that give the images the largest on-screen size in ``region`` (w, h)."""
    h = max(s[0] for s in sizes_hw)
    w = max(s[1] for s in sizes_hw)
    count = len(sizes_hw)

    def scale(columns: int) -> float:
        rows = -(-count // columns)
        return min(region[0] / columns / w, region[1] / rows / h)

    return max(range(1, count + 1), key=scale)


def per_joint_spread(hypotheses: np.ndarray, median: np.ndarray) -> np.ndarray:
    """RMS distance of hypotheses (N, T, 17, 3) to the median (T, 17, 3) per frame and joint, (T, 17)."""
    return np.sqrt(np.mean(np.sum((hypotheses - median[None]) ** 2, axis=-1), axis=0))


def _layout(result: LiftResult) -> rra.Layout:
    """Default blueprint: 3D world beside a grid of the camera views; per-person plots and the quality summary below."""
    views = tuple((f"world/cameras/{c.name}", c.name) for c in result.cameras)
    present = result.present().any(axis=1)
    tracks = [int(t) for p, t in enumerate(result.track_ids) if present[p]]
    spread = tuple((f"plots/spread/p{t}", f"p{t} spread (mm)") for t in tracks)
    energy = tuple((f"plots/energy/p{t}", f"p{t} energy") for t in tracks) if result.energy is not None else ()
    return rra.Layout(
        world="world",
        camera_views=views,
        camera_columns=camera_grid_columns([c.size for c in result.cameras]),
        spread_plots=spread,
        energy_plots=energy,
        text=("quality", "quality"),
        fps=result.fps,
    )


def bone_segments(joints: np.ndarray) -> np.ndarray:
    """Bones as (child, parent) point pairs, ``(T, 17, 3) -> (T, 16, 2, 3)``."""
    child = [c for c, _ in BONES]
    parent = [q for _, q in BONES]
    return np.stack([joints[:, child], joints[:, parent]], axis=2)


def _log_person(rec, result: LiftResult, p: int, slot: int, label: str) -> None:
    """Skeletons, median, spread, label and plots of person ``p`` (colour ``slot``) where present, a chunk at a time."""
    track = result.track_ids[p]
    colour = person_colour(slot)
    classes = [
        rra.ClassStyle(i, f"p{track} hypothesis {i}", c)
        for i, c in enumerate(hypothesis_colours(slot, result.num_hypotheses))
    ]
    classes.append(rra.ClassStyle(result.num_hypotheses, f"p{track} median", colour))
    rra.log_annotations(rec, f"world/people/p{track}", classes, JOINT_NAMES, BONES)
    present, seen = result.present()[p], result.seen()[p]
    for t in frame_chunks(result.num_frames):
        for frames, text in ((present & seen, label), (present & ~seen, f"{label} {PRIOR_LABEL}")):
            on = np.flatnonzero(frames[t])
            if len(on):
                _log_person_frames(rec, result, p, t.start + on, result.hypotheses[p, :, t][:, on], colour, text)
        rra.flush(rec)


def _log_person_frames(
    rec, result: LiftResult, p: int, idx: np.ndarray, hypotheses: np.ndarray, colour: tuple, label: str
) -> None:
    """Person ``p`` at frames ``idx`` (T_on,) where it is present, with its ``hypotheses`` (N, T_on, 17, 3) there."""
    track = result.track_ids[p]
    base = f"world/people/p{track}"
    N, T_on = result.num_hypotheses, len(idx)
    times = result.frame_times[idx]
    joint_ids = np.arange(NUM_JOINTS, dtype=np.uint16)
    hyp = np.moveaxis(hypotheses, 0, 1)  # (T_on, N, 17, 3)
    rra.send_skeletons_3d(
        rec,
        f"{base}/hypotheses",
        times,
        idx,
        hyp.reshape(-1, 3),
        np.full(T_on, N * NUM_JOINTS),
        np.repeat(np.arange(N, dtype=np.uint16), NUM_JOINTS),
        np.tile(joint_ids, N),
        radius=0.008,
    )
    median = result.median[p, idx[0] : idx[-1] + 1][idx - idx[0]]
    rra.send_skeletons_3d(
        rec,
        f"{base}/median",
        times,
        idx,
        median.reshape(-1, 3),
        np.full(T_on, NUM_JOINTS),
        np.full(NUM_JOINTS, N, dtype=np.uint16),
        joint_ids,
        radius=0.02,
    )
    rra.send_bones_3d(
        rec,
        f"{base}/median/bones",
        times,
        idx,
        bone_segments(median).reshape(-1, 2, 3),
        np.full(T_on, len(BONES)),
        radius=0.018,
        rgba=colour,
    )
    head = median[:, JOINT_NAMES.index("head")] + [0.0, 0.0, LABEL_HEIGHT_M]
    rra.send_labels_3d(rec, f"{base}/label", times, idx, head, label, colour)
    spread = per_joint_spread(hypotheses, median)
    rra.send_spheres_3d(
        rec,
        f"{base}/spread",
        times,
        idx,
        median.reshape(-1, 3),
        spread.reshape(-1),
        np.full(T_on, NUM_JOINTS),
        colour[:3] + (160,),
    )
    rra.send_series(
        rec,
        f"plots/spread/p{track}",
        times,
        idx,
        1000.0 * spread.mean(axis=1, keepdims=True),
        [f"p{track} mean joint spread"],
        [colour],
    )
    if result.energy is not None:
        energy = result.energy[p, :, idx[0] : idx[-1] + 1][:, idx - idx[0]]
        energy = np.quantile(energy, [0.05, 0.5, 0.95], axis=0).T
        names = [f"p{track} energy {q}" for q in ("5%", "median", "95%")]
        shades = [_rgba(person_hue(p), 0.85, v) for v in ENERGY_SHADES]
        rra.send_series(rec, f"plots/energy/p{track}", times, idx, energy, names, shades)


def _log_keypoints(rec, result: LiftResult, c: int) -> None:
    """2D keypoints of every person on camera ``c`` (only confident, finite points) in the person's colour."""
    camera = result.cameras[c]
    for p, track in enumerate(result.track_ids):
        entity = f"world/cameras/{camera.name}/keypoints/p{track}"
        style = rra.ClassStyle(KEYPOINTS_CLASS, f"p{track} 2D keypoints", person_colour(p))
        rra.log_annotations(rec, entity, [style], JOINT_NAMES, BONES)
        for t in frame_chunks(result.num_frames):
            kp = result.keypoints2d[c, p, t]
            valid = (kp[..., 2] > 0) & np.isfinite(kp[..., :2]).all(axis=-1)  # (t, 17)
            t_idx, j_idx = np.nonzero(valid)
            rra.send_keypoints_2d(
                rec,
                entity,
                result.frame_times[t],
                np.arange(t.start, t.stop),
                kp[t_idx, j_idx, :2],
                j_idx,
                valid.sum(axis=1),
                KEYPOINTS_CLASS,
                radius=4.0,
            )
            rra.flush(rec)


def _log_video(
    rec, entity: str, video: Path, mode: str, offset_s: float, result: LiftResult, say: Callable[[str], None]
) -> None:
    """The camera's video as an MP4 asset (re-encoded when needed) or as JPEG frames, on both timelines; a video
    rerun cannot parse as an asset (a truncated MP4) goes in as the JPEG frames that decode."""
    if mode == "asset":
        with tempfile.TemporaryDirectory() as tmp:
            source = video
            if needs_reencode(video):
                say(f"re-encoding {video.name} to H.264 for rerun")
                source = Path(tmp) / "video.mp4"
                reencode_h264(video, source)
            try:
                nanos = rra.log_video_asset(rec, entity, source)
            except RuntimeError as err:
                say(f"{video.name}: rerun cannot read it as a video ({err}); its decodable frames go in as JPEG")
                mode = "frames"
        if mode == "asset":
            stamps, frames = video_stamps(nanos / 1e9 + offset_s, result.frame_times, result.fps)
            rra.send_video_references(rec, entity, nanos, stamps, frames)
    if mode == "frames":
        for times, blobs in jpeg_frames(video):
            stamps, frames = video_stamps(times + offset_s, result.frame_times, result.fps)
            rra.send_jpeg_frames(rec, entity, stamps, frames, blobs)


def person_report(result: LiftResult, p: int) -> dict | None:
    """Person ``p``'s entry of ``meta["plausibility"]`` (one dict per person, :mod:`lifting.checks.plausibility`), if any."""
    reports = result.meta.get("plausibility") or []
    return reports[p] if p < len(reports) and isinstance(reports[p], dict) else None


def quality_flags(result: LiftResult, p: int) -> list[str]:
    """What is wrong with person ``p`` (empty when nothing is): the lift's plausibility flags (``meta["plausibility"]``:
    under the floor, sliding, spread, bone lengths, joint angles), in the words of its ``flag_text``."""
    report = person_report(result, p) or {}
    return [report.get("flag_text") or ", ".join(report.get("flags", []))] if report.get("flags") else []


def _mean_spread(result: LiftResult, p: int) -> float:
    """Mean over present frames and joints of the hypotheses' RMS distance to the median, metres."""
    total, count = 0.0, 0
    present = result.present()[p]
    for t in frame_chunks(result.num_frames):
        on = np.flatnonzero(present[t])
        if len(on):
            hyp = np.asarray(result.hypotheses[p, :, t], np.float64)[:, on]
            spread = per_joint_spread(hyp, np.asarray(result.median[p, t], np.float64)[on])
            total, count = total + spread.sum(), count + spread.size
    return total / max(count, 1)


def quality_text(result: LiftResult, flags: dict[int, list[str]]) -> str:
    """Markdown: per person frames, spread, BVH fit, flags and ``meta["plausibility"]`` entry; the lift's warnings."""
    lines = ["# Quality", ""]
    present, seen = result.present(), result.seen()
    for p, track in enumerate(result.track_ids):
        fit = result.meta.get("bvh_fit_error", {}).get(f"p{track}", {}).get("median")
        line = f"- **p{track}**: present in {present[p].sum()} / {result.num_frames} frames"
        prior = int((present[p] & ~seen[p]).sum())
        if prior:
            line += f" ({prior} of them unseen, filled by the prior)"
        if present[p].any():
            line += f", mean joint spread {1000 * _mean_spread(result, p):.0f} mm"
        if fit:
            line += f", BVH fit {1000 * fit['mean_m']:.0f} mm mean / {1000 * fit['max_m']:.0f} mm max"
        lines.append(line)
        lines += [f"  - flagged: {f}" for f in flags.get(p, [])]
    warnings = result.meta.get("warnings") or []
    if warnings:
        lines += ["", "## Warnings", ""] + [f"- {w}" for w in warnings]
    return "\n".join(lines) + "\n"


def people_centre(result: LiftResult) -> np.ndarray:
    """The mean pelvis of every present person over the clip (the origin when nobody is present), metres."""
    pelvis = np.asarray(result.median[:, :, 0], np.float64).reshape(-1, 3)
    pelvis = pelvis[np.isfinite(pelvis).all(axis=1)]
    return pelvis.mean(axis=0) if len(pelvis) else np.zeros(3)


def check_videos(result: LiftResult, video_paths: Mapping[str, Path], mode: str) -> None:
    """Raise InputError for an unknown mode, a video without a camera, or (unless ``mode`` is none) a missing video
    file or one whose image size is not its camera's (:func:`platypose.exporters.video.check_video_size`)."""
    if mode not in VIDEO_MODES:
        raise InputError(f"rrd video must be one of {', '.join(VIDEO_MODES)}, got {mode!r}", option="rrd video")
    sizes = {c.name: tuple(c.size) for c in result.cameras}
    for name, path in video_paths.items():
        if name not in sizes:
            raise InputError(f"{path}: no camera named {name!r} in the result (cameras: {', '.join(sorted(sizes))})")
        if mode != "none" and not Path(path).is_file():
            raise InputError(f"{path}: no such video file")
        if mode != "none":
            check_video_size(Path(path), name, sizes[name])


def write_rrd(
    result: LiftResult,
    path: Path | str,
    name: str,
    video_paths: Mapping[str, Path] | None = None,
    video_mode: str = "asset",
    say: Callable[[str], None] = lambda _: None,
    who: tuple[dict, dict] = ({}, {}),
) -> Path:
    """Write the rerun recording of ``result`` to ``path`` atomically; videos are matched to cameras by name.

    The recording is written by a watched child process (:mod:`exporters.watched_writer`): a disk that fills
    meanwhile is ``OSError(ENOSPC)`` naming ``path``, never a hang; nothing is left at ``path`` then.
    """
    path = Path(path)
    video_paths = {k: Path(v) for k, v in (video_paths or {}).items()}
    check_videos(result, video_paths, video_mode)
    present = result.present().any(axis=1)
    flags = {p: quality_flags(result, p) for p in range(result.num_persons) if present[p]}
    with atomic_path(path) as tmp:
        run_watched(_record, (result, name, video_paths, video_mode, flags, who), tmp, say)
    return path


def _record(
    result: LiftResult,
    name: str,
    video_paths: Mapping[str, Path],
    video_mode: str,
    flags: dict,
    who: tuple[dict, dict],
    path: Path,
    say: Callable[[str], None],
) -> None:
    """Log everything of ``result`` into a new recording at ``path`` (run by :func:`run_watched`)."""
    rec = rra.open_recording(path, "platypose", name, _layout(result))
    try:
        rra.log_world(rec, "world")
        rra.log_text(rec, "quality", quality_text(result, flags))
        for c, camera in enumerate(result.cameras):
            entity = f"world/cameras/{camera.name}"
            rra.log_camera(rec, entity, camera.K, camera.size, camera.R, camera.t)
            if camera.name in video_paths and video_mode != "none":
                video = video_paths[camera.name]
                _log_video(rec, f"{entity}/video", video, video_mode, camera.time_offset_s, result, say)
            _log_keypoints(rec, result, c)
        for p in flags:
            named = (person_report(result, p) or {}).get("flags", [])
            label = f"p{result.track_ids[p]}" + (f" (flagged: {', '.join(named)})" if named else "")
            _log_person(rec, result, p, p, label)
        reports = [person_report(result, p) or {} for p in range(result.num_persons)]
        log_floor_and_plausibility(rec, result.meta.get("floor"), reports, result.track_ids, people_centre(result))
        log_estimated_camera(rec, result)
        log_who(rec, result, *who)
    finally:
        rra.close_recording(rec)
