"""The minimal JSON schema for users who bring their own 2D keypoints (documented in docs/keypoints.md).

    {"format": "platypose-keypoints2d", "version": 1,
     "fps": 30.0, "image_size": [height, width], "layout": "coco17",
     "frames": [{"frame": 0, "people": [{"id": 7, "keypoints": [[x, y, confidence], ...]}]}]}

``layout`` is any key of ``lifting.joint_maps.KEYPOINT_LAYOUTS`` (``platypose17``
for our own joints). ``id`` is optional: give it for every person or for none
(then people are tracked). Frame ``n`` is at ``n / fps`` seconds; frame
numbers missing between the first and the last are frames with no detection.
A point with confidence 0 or null coordinates is missing.
"""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np

from platypose.detectors.sources.assemble import Person, assemble_tracks
from platypose.detectors.sources.keypoint_checks import describe_parse_error, whole_number
from platypose.detectors.tracking.tracker import TrackerConfig
from platypose.detectors.types import PoseTrack2D
from platypose.lifting.errors import InputError

FORMAT = "platypose-keypoints2d"


def _person(entry: dict) -> Person:
    values = np.array(
        [[np.nan if v is None else float(v) for v in point] for point in entry["keypoints"]], dtype=np.float64
    )
    if values.ndim != 2 or values.shape[1] != 3:
        raise ValueError("each keypoint must be [x, y, confidence]")
    return Person(values, int(entry["id"]) if "id" in entry else None)


def read_keypoints_json(path: str | Path, tracker: TrackerConfig = TrackerConfig()) -> PoseTrack2D:
    """Read a minimal-schema JSON file into tracks."""
    path = Path(path)
    try:
        content = json.loads(path.read_text())
        if content.get("format") != FORMAT:
            raise ValueError(f'"format" must be "{FORMAT}"')
        fps = float(content["fps"])
        height, width = (int(v) for v in content["image_size"])
        layout = str(content["layout"])
        frames: dict[int, list[Person]] = {}
        for entry in content["frames"]:
            number = whole_number(entry["frame"], "frame number")
            if number in frames:
                raise ValueError(f"frame {number} appears twice")
            frames[number] = [_person(person) for person in entry["people"]]
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except (OSError, ValueError, KeyError, TypeError, AttributeError, RecursionError) as err:
        raise InputError(f"{path}: not a {FORMAT} file ({describe_parse_error(err)})") from None
    ids = {person.track_id is None for people in frames.values() for person in people}
    if len(ids) > 1:
        raise InputError(f"{path}: give an id for every person or for none")
    return assemble_tracks(frames, layout, fps, (height, width), str(path), tracker)
