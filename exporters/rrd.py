"""The rerun recording of one input: video, cameras, 2D keypoints, every hypothesis, median, spread, energy.

Entity paths (all under a Z-up ``world``):

- ``world/cameras/<cam>``: camera pose and pinhole; ``.../video``: the video;
  ``.../keypoints/p<id>``: 2D keypoints of person ``<id>`` (confidence > 0).
- ``world/people/p<id>/hypotheses``: every hypothesis as a skeleton, one
  annotation class per hypothesis (class id = hypothesis index);
  ``.../median``: the median skeleton (joints in the median class) and
  ``.../median/bones``: its bones as thick orange lines;
  ``.../spread``: a wireframe sphere per joint at the median, radius = RMS
  distance of the hypotheses to the median (the per-joint spread).
- ``plots/energy/p<id>``: energy over hypotheses (5%, median, 95%) per frame;
  ``plots/spread/p<id>``: mean per-joint spread in millimetres.
"""

from __future__ import annotations

import colorsys
import tempfile
from collections.abc import Callable, Mapping
from pathlib import Path

import numpy as np

from platypose.exporters import rerun_adapter as rra
from platypose.exporters.frames import frame_chunks
from platypose.exporters.result import LiftResult
from platypose.exporters.video import jpeg_frames, needs_reencode, reencode_h264
from platypose.lifting.atomic import atomic_path
from platypose.lifting.errors import InputError
from platypose.lifting.skeleton import BONES, JOINT_NAMES, NUM_JOINTS

VIDEO_MODES = ("asset", "frames", "none")
MEDIAN_CLASS = 65000
KEYPOINTS_CLASS = 65001
MEDIAN_RGBA = (255, 140, 0, 255)
KEYPOINTS_RGBA = (40, 230, 120, 255)
SPREAD_RGBA = (255, 200, 90, 255)
ENERGY_RGBA = ((120, 160, 255, 255), (255, 255, 255, 255), (255, 120, 160, 255))


def hypothesis_colours(count: int) -> list[tuple[int, int, int, int]]:
    """Distinct muted colours for ``count`` hypotheses (hues from cyan to violet), so the median stands out."""
    hues = np.linspace(0.45, 0.8, count) if count > 1 else [0.6]
    return [tuple(int(255 * c) for c in colorsys.hsv_to_rgb(h, 0.5, 0.7)) + (255,) for h in hues]


def per_joint_spread(hypotheses: np.ndarray, median: np.ndarray) -> np.ndarray:
    """RMS distance of hypotheses (N, T, 17, 3) to the median (T, 17, 3) per frame and joint, (T, 17)."""
    return np.sqrt(np.mean(np.sum((hypotheses - median[None]) ** 2, axis=-1), axis=0))


def _layout(result: LiftResult) -> rra.Layout:
    """Default blueprint: 3D world, each camera view, energy and spread plots."""
    views = tuple((f"world/cameras/{c.name}", c.name) for c in result.cameras)
    plots = (("plots/energy", "energy"),) if result.energy is not None else ()
    return rra.Layout(world="world", camera_views=views, plots=plots + (("plots/spread", "spread (mm)"),))


def bone_segments(joints: np.ndarray) -> np.ndarray:
    """Bones as (child, parent) point pairs, ``(T, 17, 3) -> (T, 16, 2, 3)``."""
    child = [c for c, _ in BONES]
    parent = [q for _, q in BONES]
    return np.stack([joints[:, child], joints[:, parent]], axis=2)


def _log_person(rec, result: LiftResult, p: int) -> None:
    """Skeletons, median, spread and plots of person ``p`` on the frames where it is present, a chunk at a time."""
    present = result.present()[p]
    for t in frame_chunks(result.num_frames):
        on = np.flatnonzero(present[t])
        if len(on):
            _log_person_frames(rec, result, p, t.start + on, result.hypotheses[p, :, t][:, on])
            rra.flush(rec)


def _log_person_frames(rec, result: LiftResult, p: int, idx: np.ndarray, hypotheses: np.ndarray) -> None:
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
        np.full(NUM_JOINTS, MEDIAN_CLASS, dtype=np.uint16),
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
        rgba=MEDIAN_RGBA,
    )
    spread = per_joint_spread(hypotheses, median)
    rra.send_spheres_3d(
        rec,
        f"{base}/spread",
        times,
        idx,
        median.reshape(-1, 3),
        spread.reshape(-1),
        np.full(T_on, NUM_JOINTS),
        SPREAD_RGBA,
    )
    rra.send_series(
        rec,
        f"plots/spread/p{track}",
        times,
        idx,
        1000.0 * spread.mean(axis=1, keepdims=True),
        [f"p{track} mean joint spread"],
        [MEDIAN_RGBA],
    )
    if result.energy is not None:
        energy = result.energy[p, :, idx[0] : idx[-1] + 1][:, idx - idx[0]]
        energy = np.quantile(energy, [0.05, 0.5, 0.95], axis=0).T
        names = [f"p{track} energy {q}" for q in ("5%", "median", "95%")]
        rra.send_series(rec, f"plots/energy/p{track}", times, idx, energy, names, ENERGY_RGBA)


def _log_keypoints(rec, result: LiftResult, c: int) -> None:
    """2D keypoints of every person on camera ``c`` (only confident, finite points), a chunk of frames at a time."""
    camera = result.cameras[c]
    for p, track in enumerate(result.track_ids):
        for t in frame_chunks(result.num_frames):
            kp = result.keypoints2d[c, p, t]
            valid = (kp[..., 2] > 0) & np.isfinite(kp[..., :2]).all(axis=-1)  # (t, 17)
            t_idx, j_idx = np.nonzero(valid)
            rra.send_keypoints_2d(
                rec,
                f"world/cameras/{camera.name}/keypoints/p{track}",
                result.frame_times[t],
                np.arange(t.start, t.stop),
                kp[t_idx, j_idx, :2],
                j_idx,
                valid.sum(axis=1),
                KEYPOINTS_CLASS,
                radius=4.0,
            )
            rra.flush(rec)


def _log_video(rec, entity: str, video: Path, mode: str, offset_s: float, say: Callable[[str], None]) -> None:
    """The camera's video as an MP4 asset (re-encoded when needed) or as JPEG frames."""
    if mode == "asset":
        if needs_reencode(video):
            say(f"re-encoding {video.name} to H.264 for rerun")
            with tempfile.TemporaryDirectory() as tmp:
                encoded = Path(tmp) / "video.mp4"
                reencode_h264(video, encoded)
                rra.log_video_asset(rec, entity, encoded, offset_s)
        else:
            rra.log_video_asset(rec, entity, video, offset_s)
    elif mode == "frames":
        for times, blobs in jpeg_frames(video):
            rra.send_jpeg_frames(rec, entity, times + offset_s, blobs)


def check_videos(result: LiftResult, video_paths: Mapping[str, Path], mode: str) -> None:
    """Raise InputError for an unknown mode, a video without a camera, or a missing video file."""
    if mode not in VIDEO_MODES:
        raise InputError(f"rrd video must be one of {', '.join(VIDEO_MODES)}, got {mode!r}", option="rrd video")
    names = {c.name for c in result.cameras}
    for name, path in video_paths.items():
        if name not in names:
            raise InputError(f"{path}: no camera named {name!r} in the result (cameras: {', '.join(sorted(names))})")
        if mode != "none" and not Path(path).is_file():
            raise InputError(f"{path}: no such video file")


def write_rrd(
    result: LiftResult,
    path: Path | str,
    name: str,
    video_paths: Mapping[str, Path] | None = None,
    video_mode: str = "asset",
    say: Callable[[str], None] = lambda _: None,
) -> Path:
    """Write the rerun recording of ``result`` to ``path`` atomically; videos are matched to cameras by name."""
    path = Path(path)
    video_paths = {k: Path(v) for k, v in (video_paths or {}).items()}
    check_videos(result, video_paths, video_mode)
    colours = hypothesis_colours(result.num_hypotheses)
    classes = [rra.ClassStyle(i, f"hypothesis {i}", rgba) for i, rgba in enumerate(colours)]
    classes.append(rra.ClassStyle(MEDIAN_CLASS, "median", MEDIAN_RGBA))
    classes.append(rra.ClassStyle(KEYPOINTS_CLASS, "2D keypoints", KEYPOINTS_RGBA))
    with atomic_path(path) as tmp:
        rec = rra.open_recording(tmp, "platypose", name, _layout(result))
        try:
            rra.log_world(rec, "world")
            rra.log_annotations(rec, "world", classes, JOINT_NAMES, BONES)
            for c, camera in enumerate(result.cameras):
                entity = f"world/cameras/{camera.name}"
                rra.log_camera(rec, entity, camera.K, camera.size, camera.R, camera.t)
                if camera.name in video_paths and video_mode != "none":
                    _log_video(rec, f"{entity}/video", video_paths[camera.name], video_mode, camera.time_offset_s, say)
                _log_keypoints(rec, result, c)
            for p in range(result.num_persons):
                _log_person(rec, result, p)
        finally:
            rra.close_recording(rec)
    return path
