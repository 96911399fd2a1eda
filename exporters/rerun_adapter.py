"""The one module that talks to rerun-sdk (pinned 0.41.x): thin functions over arrays.

Everything time-varying is sent with columnar ``send_columns`` on two timelines,
``time`` (seconds, the shared clock) and, for per-frame data, ``frame``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import rerun as rr
import rerun.blueprint as rrb

TIME = "time"
FRAME = "frame"


@dataclass(frozen=True)
class ClassStyle:
    """How one annotation class is drawn: id, label and RGBA colour."""

    class_id: int
    label: str
    rgba: tuple[int, int, int, int]


@dataclass(frozen=True)
class Layout:
    """The default blueprint: one 3D view, one 2D view per camera, and the plots."""

    world: str
    camera_views: tuple[tuple[str, str], ...]  # (entity path, title)
    plots: tuple[tuple[str, str], ...]  # (entity path, title)


def open_recording(path: Path, application_id: str, recording_name: str, layout: Layout) -> rr.RecordingStream:
    """A recording that streams to the file ``path`` with ``layout`` as its default blueprint."""
    rec = rr.RecordingStream(application_id, send_properties=True)
    rec.save(path, default_blueprint=_blueprint(layout))
    rec.send_recording_name(recording_name)
    return rec


def flush(rec: rr.RecordingStream) -> None:
    """Write everything logged so far to the file (without this, a long recording piles up in memory)."""
    rec.flush()


def close_recording(rec: rr.RecordingStream) -> None:
    """Flush everything and finish the file (footer included)."""
    rec.flush()
    rec.disconnect()


def _blueprint(layout: Layout) -> rrb.Blueprint:
    """Blueprint object for ``layout``."""
    view3d = rrb.Spatial3DView(origin=layout.world, name="3D hypotheses")
    cameras = [rrb.Spatial2DView(origin=origin, name=title) for origin, title in layout.camera_views]
    plots = [rrb.TimeSeriesView(origin=origin, name=title) for origin, title in layout.plots]
    right = [rrb.Vertical(*cameras)] if cameras else []
    right += [rrb.Vertical(*plots)] if plots else []
    main = rrb.Horizontal(view3d, rrb.Vertical(*right), column_shares=[3, 2]) if right else view3d
    return rrb.Blueprint(main, rrb.TimePanel(timeline=TIME), collapse_panels=False)


def _indexes(times: np.ndarray, frames: np.ndarray | None) -> list[rr.TimeColumn]:
    """Time (and frame) index columns."""
    cols = [rr.TimeColumn(TIME, duration=np.asarray(times, dtype=np.float64))]
    if frames is not None:
        cols.append(rr.TimeColumn(FRAME, sequence=np.asarray(frames, dtype=np.int64)))
    return cols


def log_world(rec: rr.RecordingStream, entity: str) -> None:
    """Declare ``entity`` as a right-handed, Z-up world."""
    rec.log(entity, rr.ViewCoordinates.RIGHT_HAND_Z_UP, static=True)


def log_annotations(
    rec: rr.RecordingStream,
    entity: str,
    classes: Sequence[ClassStyle],
    keypoint_names: Sequence[str],
    connections: Sequence[tuple[int, int]],
) -> None:
    """Annotation classes under ``entity``, each with the skeleton's keypoints and bones."""
    keypoints = [rr.AnnotationInfo(id=i, label=n) for i, n in enumerate(keypoint_names)]
    descriptions = [
        rr.ClassDescription(
            info=rr.AnnotationInfo(id=c.class_id, label=c.label, color=c.rgba),
            keypoint_annotations=keypoints,
            keypoint_connections=list(connections),
        )
        for c in classes
    ]
    rec.log(entity, rr.AnnotationContext(descriptions), static=True)


def log_camera(
    rec: rr.RecordingStream, entity: str, K: np.ndarray, size_hw: tuple[int, int], R: np.ndarray, t: np.ndarray
) -> None:
    """A pinhole camera with ``x_cam = R @ X + t`` (OpenCV axes: x right, y down, z forward)."""
    rec.log(entity, rr.Transform3D(translation=t, mat3x3=R, relation=rr.TransformRelation.ChildFromParent), static=True)
    rec.log(
        entity,
        rr.Pinhole(image_from_camera=K, resolution=[size_hw[1], size_hw[0]], camera_xyz=rr.ViewCoordinates.RDF),
        static=True,
    )


def send_skeletons_3d(
    rec: rr.RecordingStream,
    entity: str,
    times: np.ndarray,
    frames: np.ndarray,
    points: np.ndarray,
    counts: np.ndarray,
    class_ids: np.ndarray,
    keypoint_ids: np.ndarray,
    radius: float,
) -> None:
    """Per-frame 3D points (sum(counts), 3) in ``counts`` per frame; class and keypoint ids (M,) static per slot."""
    rec.log(
        entity,
        rr.Points3D.from_fields(class_ids=class_ids, keypoint_ids=keypoint_ids, radii=radius, show_labels=False),
        static=True,
    )
    columns = rr.Points3D.columns(positions=np.asarray(points, dtype=np.float32)).partition(counts)
    rr.send_columns(entity, indexes=_indexes(times, frames), columns=columns, recording=rec)


def send_bones_3d(
    rec: rr.RecordingStream,
    entity: str,
    times: np.ndarray,
    frames: np.ndarray,
    segments: np.ndarray,
    counts: np.ndarray,
    radius: float,
    rgba: tuple[int, int, int, int],
) -> None:
    """Per-frame thick line segments (M, 2, 3) split into frames by ``counts``, one colour."""
    rec.log(entity, rr.LineStrips3D.from_fields(radii=radius, colors=[rgba]), static=True)
    columns = rr.LineStrips3D.columns(strips=np.asarray(segments, dtype=np.float32)).partition(counts)
    rr.send_columns(entity, indexes=_indexes(times, frames), columns=columns, recording=rec)


def send_spheres_3d(
    rec: rr.RecordingStream,
    entity: str,
    times: np.ndarray,
    frames: np.ndarray,
    centres: np.ndarray,
    radii: np.ndarray,
    counts: np.ndarray,
    rgba: tuple[int, int, int, int],
) -> None:
    """Per-frame wireframe spheres: centres (M, 3) and radii (M,) split into frames by ``counts``."""
    rec.log(
        entity,
        rr.Ellipsoids3D.from_fields(colors=[rgba], fill_mode=rr.components.FillMode.MajorWireframe, line_radii=0.002),
        static=True,
    )
    half_sizes = np.repeat(np.asarray(radii, dtype=np.float32)[:, None], 3, axis=1)
    columns = rr.Ellipsoids3D.columns(centers=np.asarray(centres, dtype=np.float32), half_sizes=half_sizes)
    rr.send_columns(entity, indexes=_indexes(times, frames), columns=columns.partition(counts), recording=rec)


def send_keypoints_2d(
    rec: rr.RecordingStream,
    entity: str,
    times: np.ndarray,
    frames: np.ndarray,
    points: np.ndarray,
    keypoint_ids: np.ndarray,
    counts: np.ndarray,
    class_id: int,
    radius: float,
) -> None:
    """Per-frame 2D keypoints (M, 2) pixels with their keypoint ids (M,), split by ``counts``."""
    rec.log(entity, rr.Points2D.from_fields(class_ids=[class_id], radii=radius, show_labels=False), static=True)
    columns = rr.Points2D.columns(
        positions=np.asarray(points, dtype=np.float32), keypoint_ids=np.asarray(keypoint_ids, dtype=np.uint16)
    ).partition(counts)
    rr.send_columns(entity, indexes=_indexes(times, frames), columns=columns, recording=rec)


def send_series(
    rec: rr.RecordingStream,
    entity: str,
    times: np.ndarray,
    frames: np.ndarray,
    values: np.ndarray,
    names: Sequence[str],
    rgba: Sequence[tuple[int, int, int, int]],
) -> None:
    """Time series: ``values`` (T, K), one line per column with its name and colour."""
    rec.log(entity, rr.SeriesLines(names=list(names), colors=list(rgba)), static=True)
    rr.send_columns(entity, indexes=_indexes(times, frames), columns=rr.Scalars.columns(scalars=values), recording=rec)


def log_video_asset(rec: rr.RecordingStream, entity: str, video: Path, time_offset_s: float) -> int:
    """Embed an MP4 (H.264/AV1) and reference each of its frames at its own time + offset; returns the frame count."""
    asset = rr.AssetVideo(path=video)
    rec.log(entity, asset, static=True)
    nanos = asset.read_frame_timestamps_nanos()
    rr.send_columns(
        entity,
        indexes=[rr.TimeColumn(TIME, duration=nanos / 1e9 + time_offset_s)],
        columns=rr.VideoFrameReference.columns_nanos(nanos),
        recording=rec,
    )
    return len(nanos)


def send_jpeg_frames(rec: rr.RecordingStream, entity: str, times: np.ndarray, blobs: Sequence[bytes]) -> None:
    """Video frames as JPEG images at ``times`` seconds."""
    columns = rr.EncodedImage.columns(blob=list(blobs), media_type=["image/jpeg"] * len(blobs))
    rr.send_columns(entity, indexes=_indexes(times, None), columns=columns, recording=rec)
