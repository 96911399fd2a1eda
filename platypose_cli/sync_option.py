"""``--sync auto|none|offsets.json``: put the views of a take on one clock before they are combined.

``auto`` estimates each view's offset from its 2D keypoints (``lifting.sync``) and reports it with
its confidence; ``none`` keeps the calibration's ``time_offset_s``; a JSON file gives the offsets in
seconds by camera name (``{"cam01": 0.0, "cam02": 0.12}``, or the ``offsets_s`` of a file written
by ``auto``).
"""

from __future__ import annotations

import json
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np

from platypose.lifting.atomic import write_text_atomic
from platypose.lifting.calibration.matching import match_views
from platypose.lifting.camera import Camera
from platypose.lifting.errors import InputError

SYNC_HELP = (
    "Camera synchronisation: auto (estimate each view's time offset from the keypoints' motion, "
    "refined by reprojection), none (use the calibration's time_offset_s), or an offsets.json "
    '({"cam01": 0.0, "cam02": 0.12}, seconds to add to each view\'s frame times).'
)
LOW_CONFIDENCE = 0.2  # below this the estimated offset is reported as unreliable


def read_offsets(path: Path, camera_names: Sequence[str]) -> list[float]:
    """Offsets (s) per camera, in ``camera_names`` order, from a JSON object keyed by camera or view name."""
    try:
        data = json.loads(path.read_text(encoding="utf-8"))
    except FileNotFoundError:
        raise InputError(f"{path}: offsets file not found (--sync takes auto, none or an offsets .json)") from None
    except (UnicodeDecodeError, json.JSONDecodeError) as err:
        raise InputError(f"{path}: not valid JSON ({err})") from None
    offsets = data.get("offsets_s", data) if isinstance(data, dict) else None
    if not isinstance(offsets, dict) or not all(isinstance(v, (int, float)) for v in offsets.values()):
        raise InputError(f"{path}: expected a JSON object of camera name -> offset in seconds")
    try:
        matched = match_views(camera_names, list(offsets))
    except InputError as err:
        raise InputError(f"{path}: {err}") from None
    values = [float(offsets[matched[name]]) for name in camera_names]
    if not all(np.isfinite(values)):
        raise InputError(f"{path}: offsets must be finite numbers of seconds")
    return values


def write_offsets(path: Path, cameras: Sequence[Camera], confidence: Sequence[float]) -> None:
    """Write the cameras' offsets and their confidence as JSON that ``--sync`` reads back."""
    data = {
        "offsets_s": {c.name: c.time_offset_s for c in cameras},
        "confidence": {c.name: round(float(v), 3) for c, v in zip(cameras, confidence)},
    }
    path.parent.mkdir(parents=True, exist_ok=True)
    write_text_atomic(path, json.dumps(data, indent=1) + "\n")


def sync_cameras(
    mode: str,
    keypoints: Sequence[np.ndarray],
    frame_times: Sequence[np.ndarray],
    cameras: Sequence[Camera],
    log: Callable[[str], None],
    warn: Callable[[str], None],
    out: Path | None = None,
) -> list[Camera]:
    """The cameras with the time offsets ``mode`` asks for; ``keypoints[c]`` (T_c, P, J, 3) per view.

    With ``auto`` each offset is logged with its confidence (and written to ``out`` when given);
    a low confidence is a warning.
    """
    from platypose.lifting.sync import estimate_offsets, main_person, with_offsets

    if mode == "none" or len(cameras) < 2:
        return list(cameras)
    if mode != "auto":
        return with_offsets(cameras, read_offsets(Path(mode), [c.name for c in cameras]))
    estimate = estimate_offsets([main_person(k) for k in keypoints], frame_times, cameras)
    synced = with_offsets(cameras, estimate.offsets_s)
    rows = zip(synced[1:], estimate.offsets_frames[1:], estimate.confidence[1:], estimate.at_limit[1:])
    for camera, frames, confidence, at_limit in rows:
        log(
            f"sync {camera.name}: {camera.time_offset_s:+.3f} s ({frames:+.1f} frames) after {synced[0].name}, "
            f"confidence {confidence:.2f}"
        )
        if confidence < LOW_CONFIDENCE:
            warn(f"sync {camera.name}: low confidence {confidence:.2f}; check the offset or pass an offsets.json")
        if at_limit:
            warn(
                f"sync {camera.name}: the reprojection error still falls at 2 frames from the motion estimate, "
                "where the search stops: the offset or the calibration may be off by that much"
            )
    log(
        f"sync: median reprojection error {estimate.error_before_px:.1f} px as recorded, "
        f"{estimate.error_after_px:.1f} px with the offsets"
    )
    if out is not None:
        write_offsets(out, synced, estimate.confidence)
    return synced
