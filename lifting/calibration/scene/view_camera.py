"""The camera a one-view lift without ``--cams`` stands on: roll and pitch from the scene's lines, the focal length
from the most trusted source that has one, the height (and floor) left to the people.

Focal length, in this order of trust: the video's metadata (:func:`platypose.lifting.calibration.lens.lens_focal`;
the lines then give the pitch at it), the two horizontal vanishing points
(:func:`platypose.lifting.calibration.scene.estimate.scene_camera`), the lens prior (said once: "focal length not
measured"). Where the scene gives nothing (no line detector, no lines, a moving camera) the lift assumes what it
always did: a level camera at the origin with the field-of-view prior
(:func:`platypose.lifting.calibration.defaults.default_camera`), its floor's pitch searched under the people.
"""

from __future__ import annotations

from dataclasses import dataclass, field

from platypose.lifting.calibration.defaults import default_camera
from platypose.lifting.calibration.lens import METADATA, PRIOR, prior_focal
from platypose.lifting.calibration.pose_above_floor import pitched, posed_camera
from platypose.lifting.calibration.scene.estimate import SceneCamera
from platypose.lifting.camera import Camera

HEIGHT_SOURCE = "people (stance ankles on one floor, adult stature for scale)"
LEVEL_ASSUMED = "a level camera at the origin with a 53 degree diagonal field of view is assumed"
FALLBACK = "camera from the scene's lines not used"


@dataclass(frozen=True)
class AssumedCamera:
    """The camera of one uncalibrated view, at the origin in a z-up world (its height above the floor is the
    people's, found later); ``level_known``: its roll and pitch are the scene's, so the floor's tilt is not searched
    under the people; ``record`` (``meta["camera"]``): each quantity's value, standard deviation and source;
    ``lines``: what to log, once each."""

    camera: Camera
    level_known: bool
    record: dict = field(default_factory=dict)
    lines: tuple[str, ...] = ()


def fallback_camera(name: str, size: tuple[int, int], why: str) -> AssumedCamera:
    """Today's assumed camera (level, at the origin, field-of-view prior) and one line saying ``why``."""
    line = f"{FALLBACK} ({why}): {LEVEL_ASSUMED}, its pitch and height from the people"
    record = {"source": "assumed level (field-of-view prior)", "scene": why}
    return AssumedCamera(default_camera(name, *size), False, record, (line,))


def assumed_camera(
    name: str, size: tuple[int, int], scene: SceneCamera, metadata_focal: float | None = None
) -> AssumedCamera:
    """The camera of view ``name`` (image ``size`` (height, width)) from its ``scene`` estimate, with the focal
    length of the video's metadata where it has one (``metadata_focal`` px; the scene's pitch is then its)."""
    if scene.problem is not None:
        return fallback_camera(name, size, scene.problem)
    if metadata_focal is not None:
        focal, focal_sd, focal_source = metadata_focal, None, METADATA
    elif scene.focal_px is not None:
        focal, focal_sd, focal_source = scene.focal_px, scene.sd["focal_px"], scene.source["focal_px"]
    else:
        focal, focal_sd, focal_source = prior_focal(size), None, PRIOR
    record = {
        "roll_deg": _entry(scene.roll_deg, scene.sd["roll_deg"], scene.source["roll_deg"]),
        "pitch_deg": _entry(scene.pitch_deg, scene.sd["pitch_deg"], scene.source["pitch_deg"]),
        "focal_px": _entry(focal, focal_sd, focal_source),
        "height_m": {"source": HEIGHT_SOURCE},
        "segments": scene.segments,
    }
    focal_text = f"{focal:.0f} px" + ("" if focal_sd is None else f" +- {focal_sd:.0f}")
    lines = [
        f"camera from the scene's lines ({scene.segments} segments): rolled {scene.roll_deg:.1f} +- "
        f"{scene.sd['roll_deg']:.1f} degrees, {pitched(scene.pitch_deg, scene.sd['pitch_deg'])} "
        f"({scene.source['pitch_deg']}); focal length {focal_text} ({focal_source}); height from the "
        f"{HEIGHT_SOURCE}"
    ]
    if scene.focal_note is not None and metadata_focal is None:
        record["focal_note"] = scene.focal_note
        lines.append(f"{scene.focal_note}; the {PRIOR} is used")
    camera = posed_camera(name, size, focal, scene.pitch_deg, scene.roll_deg, 0.0)
    return AssumedCamera(camera, True, record, tuple(lines))


def _entry(value: float, sd: float | None, source: str) -> dict:
    return {"value": float(value), "sd": None if sd is None else float(sd), "source": source}
