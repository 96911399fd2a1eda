"""The one module that talks to rerun-sdk (pinned 0.41.x): thin functions over arrays.

Everything time-varying is sent with columnar ``send_columns`` on two timelines,
``time`` (the shared clock, whole nanoseconds rounded from seconds, so that the
same second always gives the same stamp) and ``frame`` (output frame index).
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
    """The default blueprint: the 3D world beside the camera views (a grid), per-person plots and a text below."""

    world: str
    camera_views: tuple[tuple[str, str], ...]  # (entity path, title)
    camera_columns: int  # columns of the camera grid
    spread_plots: tuple[tuple[str, str], ...]  # (entity path, title), one per person
    energy_plots: tuple[tuple[str, str], ...]  # (entity path, title), one per person
    text: tuple[str, str] | None  # (entity path, title) of a text document
    fps: float  # playback rate of the frame timeline


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
    """Blueprint object for ``layout``; it opens paused (at the start of the recording)."""
    view3d = rrb.Spatial3DView(origin=layout.world, name="3D: hypotheses, median, cameras")
    cameras = [rrb.Spatial2DView(origin=origin, name=title) for origin, title in layout.camera_views]
    top: rrb.Container | rrb.View = view3d
    if cameras:
        grid = cameras[0] if len(cameras) == 1 else rrb.Grid(*cameras, grid_columns=layout.camera_columns)
        top = rrb.Horizontal(view3d, grid, column_shares=[1, 1])
    bottom: list[rrb.Container | rrb.View] = []
    spread = [rrb.TimeSeriesView(origin=o, name=t) for o, t in layout.spread_plots]
    energy = [rrb.TimeSeriesView(origin=o, name=t) for o, t in layout.energy_plots]
    if spread:
        bottom.append(rrb.Grid(*spread) if len(spread) > 1 else spread[0])
    if energy:
        bottom.append(rrb.Tabs(*energy) if len(energy) > 1 else energy[0])
    if layout.text is not None:
        bottom.append(rrb.TextDocumentView(origin=layout.text[0], name=layout.text[1]))
    main = rrb.Vertical(top, rrb.Horizontal(*bottom), row_shares=[3, 1]) if bottom else top
    panel = rrb.TimePanel(timeline=TIME, fps=layout.fps, play_state="paused")
    return rrb.Blueprint(main, panel, collapse_panels=False)


def nanoseconds(seconds: np.ndarray) -> np.ndarray:
    """Seconds (float) as whole nanoseconds (int64), rounded: the stamps every entity is logged at."""
    return np.round(np.asarray(seconds, dtype=np.float64) * 1e9).astype(np.int64)


def _indexes(times: np.ndarray, frames: np.ndarray | None) -> list[rr.TimeColumn]:
    """Time (and frame) index columns."""
    cols = [rr.TimeColumn(TIME, duration=nanoseconds(times).astype("timedelta64[ns]"))]
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


def log_video_asset(rec: rr.RecordingStream, entity: str, video: Path) -> np.ndarray:
    """Embed an MP4 (H.264/AV1) as a static asset; return its frame timestamps in nanoseconds (V,).

    RuntimeError, with nothing logged, when rerun cannot parse the file (a truncated or damaged MP4)."""
    asset = rr.AssetVideo(path=video)
    nanos = np.asarray(asset.read_frame_timestamps_nanos(), dtype=np.int64)  # parses the MP4: before logging it
    rec.log(entity, asset, static=True)
    return nanos


def send_video_references(
    rec: rr.RecordingStream, entity: str, video_nanos: np.ndarray, stamps_ns: np.ndarray, frames: np.ndarray
) -> None:
    """Show the asset's frames (timestamps ``video_nanos`` (V,)) at clock stamps ``stamps_ns`` (V,) ns.

    Frames with ``frames`` (V,) >= 0 are also put on the frame timeline at that output frame.
    """
    for rows, with_frames in ((frames >= 0, True), (frames < 0, False)):
        if rows.any():
            indexes = [rr.TimeColumn(TIME, duration=stamps_ns[rows].astype("timedelta64[ns]"))]
            if with_frames:
                indexes.append(rr.TimeColumn(FRAME, sequence=frames[rows]))
            columns = rr.VideoFrameReference.columns_nanos(video_nanos[rows])
            rr.send_columns(entity, indexes=indexes, columns=columns, recording=rec)


def send_jpeg_frames(
    rec: rr.RecordingStream, entity: str, stamps_ns: np.ndarray, frames: np.ndarray, blobs: Sequence[bytes]
) -> None:
    """Video frames as JPEG images at clock stamps ``stamps_ns`` (B,) ns; ``frames`` >= 0 also on the frame timeline."""
    for rows, with_frames in ((frames >= 0, True), (frames < 0, False)):
        idx = np.flatnonzero(rows)
        if len(idx):
            indexes = [rr.TimeColumn(TIME, duration=stamps_ns[idx].astype("timedelta64[ns]"))]
            if with_frames:
                indexes.append(rr.TimeColumn(FRAME, sequence=frames[idx]))
            picked = [blobs[i] for i in idx]
            columns = rr.EncodedImage.columns(blob=picked, media_type=["image/jpeg"] * len(picked))
            rr.send_columns(entity, indexes=indexes, columns=columns, recording=rec)


def send_labels_3d(
    rec: rr.RecordingStream,
    entity: str,
    times: np.ndarray,
    frames: np.ndarray,
    points: np.ndarray,
    label: str,
    rgba: tuple[int, int, int, int],
) -> None:
    """One labelled point per frame (T, 3), e.g. a person's name floating above the head; the label is logged on
    these frames (another call may label other frames otherwise)."""
    rec.log(entity, rr.Points3D.from_fields(colors=[rgba], radii=0.01, show_labels=True), static=True)
    columns = rr.Points3D.columns(positions=np.asarray(points, dtype=np.float32), labels=[label] * len(points))
    rr.send_columns(entity, indexes=_indexes(times, frames), columns=columns, recording=rec)


def log_text(rec: rr.RecordingStream, entity: str, markdown: str) -> None:
    """A static Markdown document."""
    rec.log(entity, rr.TextDocument(markdown, media_type=rr.MediaType.MARKDOWN), static=True)
