"""Read MMPose prediction JSON and COCO-style keypoint JSON (incl. PoseTrack-style ``track_id``) into tracks.

Accepted shapes:

- MMPose ``--save-predictions``: ``{"meta_info": ..., "instance_info": [{"frame_id": n, "instances": [...]}]}``,
  or the bare list of ``{"frame_id", "instances"}``; each instance has ``keypoints`` [[x, y], ...],
  ``keypoint_scores`` [...], optional ``bbox`` and ``track_id``.
- COCO-style: ``{"images": [{"id", "frame_id"?}], "annotations": [{"image_id", "keypoints": [x, y, v, ...],
  "track_id"?}]}``; frames are the images in ``frame_id`` (else ``id``) order; ``v`` > 0 counts as seen
  with confidence 1 unless a ``keypoint_scores`` list is given.

The first frame in the file is at time 0 (MMPose numbers video frames from 0 or 1
depending on the tool). The layout comes from the keypoint count (17 COCO, 26 Halpe).
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from platypose.detectors.keypoints import model_layout
from platypose.detectors.sources.assemble import Person, assemble_tracks
from platypose.detectors.sources.keypoint_checks import describe_parse_error, whole_number
from platypose.detectors.sources.video import timing_from_video
from platypose.detectors.tracking.tracker import TrackerConfig
from platypose.detectors.types import PoseTrack2D
from platypose.lifting.errors import InputError


def _mmpose_person(instance: dict) -> Person:
    """One MMPose instance -> Person (S, 3)."""
    xy = np.asarray(instance["keypoints"], dtype=np.float64).reshape(-1, 2)
    scores = np.asarray(instance["keypoint_scores"], dtype=np.float64).reshape(-1)
    if len(scores) != len(xy):
        raise ValueError(f"{len(xy)} keypoints but {len(scores)} keypoint_scores")
    track_id = instance.get("track_id")
    return Person(np.concatenate([xy, scores[:, None]], axis=1), None if track_id is None else int(track_id))


def _coco_person(annotation: dict) -> Person:
    """One COCO-style annotation -> Person (S, 3); visibility flags become confidence 1 or 0."""
    values = np.asarray(annotation["keypoints"], dtype=np.float64).reshape(-1, 3)
    confidence = (values[:, 2] > 0).astype(np.float64)
    if "keypoint_scores" in annotation:
        confidence = confidence * np.asarray(annotation["keypoint_scores"], dtype=np.float64).reshape(-1)
    track_id = annotation.get("track_id")
    return Person(np.column_stack([values[:, :2], confidence]), None if track_id is None else int(track_id))


def parse_frames(content) -> dict[int, list[Person]]:
    """Parsed JSON (either shape above) -> frame number -> people; ValueError naming what is wrong."""
    if isinstance(content, dict) and "annotations" in content:
        images = sorted(content.get("images", []), key=lambda im: (im.get("frame_id", im["id"]), im["id"]))
        number = {image["id"]: n for n, image in enumerate(images)}
        frames: dict[int, list[Person]] = {n: [] for n in number.values()}
        for annotation in content["annotations"]:
            if annotation["image_id"] not in number:
                raise ValueError(f"annotation for unknown image_id {annotation['image_id']}")
            if annotation.get("num_keypoints", 1) > 0 and "keypoints" in annotation:
                frames[number[annotation["image_id"]]].append(_coco_person(annotation))
        return frames
    entries = content.get("instance_info") if isinstance(content, dict) else content
    if not isinstance(entries, list) or not all(isinstance(e, dict) and "instances" in e for e in entries):
        raise ValueError("neither MMPose predictions (instance_info with frame_id/instances) nor COCO-style JSON")
    frames = {}
    for n, entry in enumerate(entries):
        frame = whole_number(entry.get("frame_id", n), "frame_id")
        if frame in frames:
            raise ValueError(f"frame_id {frame} appears twice")
        frames[frame] = [_mmpose_person(instance) for instance in entry["instances"]]
    return frames


def read_mmpose_json(
    path: str | Path,
    fps: float | None = None,
    image_size: tuple[int, int] | None = None,
    tracker: TrackerConfig = TrackerConfig(),
) -> PoseTrack2D:
    """Read an MMPose / COCO-style JSON file into tracks; fps and image size not given come from the video beside it."""
    path = Path(path)
    try:
        content = json.loads(path.read_text())
        frames = parse_frames(content)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (OSError, ValueError, KeyError, TypeError, RecursionError) as err:
        raise InputError(f"{path}: not MMPose or COCO-style keypoint JSON ({describe_parse_error(err)})") from None
    if not frames:
        raise InputError(f"{path}: no frames")
    images = content.get("images", []) if isinstance(content, dict) else []
    if image_size is None and images and "height" in images[0]:
        image_size = (int(images[0]["height"]), int(images[0]["width"]))
    fps, image_size = timing_from_video(path, fps, image_size)
    everyone = [person for people in frames.values() for person in people]
    if not everyone:
        raise InputError(f"{path}: no person in any frame")
    try:
        layout = model_layout(everyone[0].keypoints.shape[0])
    except ValueError as err:
        raise InputError(f"{path}: {err}") from None
    return assemble_tracks(frames, layout, fps, image_size, str(path), tracker, time_origin=min(frames))
