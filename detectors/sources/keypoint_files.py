"""Our own 2D keypoint files: npz and CSV (written by ``platypose detect``, read back by every command).

npz fields (as in the lift result npz, one camera): ``keypoints2d`` (1, P, T, 17, 3)
x_px, y_px, confidence (NaN, NaN, 0 when missing), ``frame_times`` (T,) s,
``track_ids`` (P,), ``joint_names`` (17,), ``image_size`` (2,) height, width,
``source``. The reader also takes a lift result npz (``camera`` picks the view;
the image size then comes from its ``cameras`` JSON).

CSV: header ``person,frame,time,joint,x,y,confidence``, one row per person,
frame and joint; ``person`` is the track ID, ``frame`` the index into the
frames, ``joint`` our joint name; a missing joint has empty x and y and
confidence 0. The CSV has no image size: it comes from the caller or the
video beside the file.
"""

from __future__ import annotations

import csv
import json
import zipfile
from dataclasses import replace
from pathlib import Path

import numpy as np

from platypose.detectors.sources.keypoint_checks import check_tracks
from platypose.detectors.sources.video import timing_from_video
from platypose.detectors.types import PoseTrack2D
from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import atomic_open
from platypose.lifting.files.npz_limits import check_npz_sizes
from platypose.lifting.skeleton import JOINT_INDEX, JOINT_NAMES

CSV_HEADER = ("person", "frame", "time", "joint", "x", "y", "confidence")


def write_keypoints_npz(tracks: PoseTrack2D, path: str | Path) -> Path:
    """Write tracks to our 2D npz layout, atomically."""
    path = Path(path)
    with atomic_open(path) as stream:
        np.savez(
            stream,
            keypoints2d=tracks.keypoints.transpose(1, 0, 2, 3)[None],
            frame_times=tracks.frame_times,
            track_ids=tracks.track_ids,
            joint_names=np.array(JOINT_NAMES),
            image_size=np.array(tracks.image_size, dtype=np.int64),
            source=np.array(tracks.source),
        )
    return path


def read_keypoints_npz(path: str | Path, camera: int = 0) -> PoseTrack2D:
    """Read our 2D npz (or one camera of a lift result npz) into tracks."""
    path = Path(path)
    try:
        check_npz_sizes(path)
        with np.load(path, allow_pickle=False) as data:
            if "keypoints2d" not in data.files:
                raise ValueError("no 'keypoints2d' field: not a platypose keypoint or result file")
            if [str(n) for n in data["joint_names"]] != list(JOINT_NAMES):
                raise ValueError("joint_names differ from platypose's 17 joints")
            views = data["keypoints2d"]
            if views.ndim != 5 or not 0 <= camera < views.shape[0]:
                raise ValueError(f"keypoints2d {views.shape} has no camera {camera}")
            if "image_size" in data.files:
                image_size = tuple(int(v) for v in data["image_size"])
            else:
                image_size = tuple(json.loads(str(data["cameras"]))["cameras"][camera]["size"])
            source = str(data["source"]) if "source" in data.files else str(path)
            tracks = PoseTrack2D(
                views[camera].transpose(1, 0, 2, 3), data["frame_times"], data["track_ids"], image_size, str(path)
            )
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except EOFError:
        raise InputError(f"{path}: empty or truncated npz file") from None
    except (OSError, KeyError, ValueError, IndexError, zipfile.BadZipFile, json.JSONDecodeError, RecursionError) as err:
        raise InputError(f"{path}: {err}") from None
    return replace(check_tracks(tracks), source=source)


def write_keypoints_csv(tracks: PoseTrack2D, path: str | Path) -> Path:
    """Write tracks as long CSV rows ``person,frame,time,joint,x,y,confidence``, atomically."""
    path = Path(path)
    with atomic_open(path, "w", newline="") as stream:
        writer = csv.writer(stream)
        writer.writerow(CSV_HEADER)
        for p, track_id in enumerate(tracks.track_ids.tolist()):
            for t, time in enumerate(tracks.frame_times.tolist()):
                for j, name in enumerate(JOINT_NAMES):
                    x, y, c = tracks.keypoints[t, p, j].tolist()
                    seen = c > 0
                    writer.writerow(
                        (
                            track_id,
                            t,
                            f"{time:.6f}",
                            name,
                            f"{x:.3f}" if seen else "",
                            f"{y:.3f}" if seen else "",
                            f"{c:.4f}",
                        )
                    )
    return path


def read_keypoints_csv(path: str | Path, image_size: tuple[int, int] | None = None) -> PoseTrack2D:
    """Read our 2D CSV into tracks; ``image_size`` (height, width) from the caller or the video beside it."""
    path = Path(path)
    if not path.is_file():
        raise InputError(f"{path}: no such file")
    _, image_size = timing_from_video(path, 1.0, image_size)
    try:
        with open(path, newline="") as stream:
            reader = csv.reader(stream)
            if tuple(next(reader, ())) != CSV_HEADER:
                raise ValueError(f"header must be {','.join(CSV_HEADER)}")
            rows = [row for row in reader if row]
        for line, row in enumerate(rows, start=2):
            if len(row) != len(CSV_HEADER):
                raise ValueError(f"row {line} has {len(row)} values, not {len(CSV_HEADER)}")
        person = np.array([int(r[0]) for r in rows])
        frame = np.array([int(r[1]) for r in rows])
        time = np.array([float(r[2]) for r in rows])
        joint = np.array([JOINT_INDEX[r[3]] for r in rows])
        values = np.array([[float(r[4] or "nan"), float(r[5] or "nan"), float(r[6])] for r in rows])
    except (ValueError, IndexError) as err:
        raise InputError(f"{path}: {err}") from None
    except KeyError as err:
        raise InputError(f"{path}: unknown joint name {err}") from None
    if len(rows) == 0 or frame.min() < 0:
        raise InputError(f"{path}: no rows or a negative frame index")
    present = np.unique(frame)
    if present[-1] + 1 > len(present):
        gap = int(np.argmax(present != np.arange(len(present))))
        raise InputError(f"{path}: frame indices are not contiguous (frame {gap} has no row)")
    ids, column = np.unique(person, return_inverse=True)
    keypoints = np.full((frame.max() + 1, len(ids), 17, 3), np.nan, dtype=np.float32)
    keypoints[..., 2] = 0.0
    keypoints[frame, column, joint] = values
    times = np.full(frame.max() + 1, np.nan)
    times[frame] = time
    if np.isnan(times).any():
        gap = int(np.argmax(np.isnan(times)))
        raise InputError(f"{path}: frame indices are not contiguous (frame {gap} has no row)")
    return check_tracks(PoseTrack2D(keypoints, times, ids, image_size, str(path)))
