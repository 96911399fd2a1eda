"""The camera a one-view lift without ``--cams`` stands on: roll and pitch from the scene's lines checked against the
people's verticals, the focal length fused from the sources that measure it, the height (and floor) left to the
people. The lens's radial distortion is the scene's (:mod:`platypose.lifting.calibration.scene.distortion`), as OpenCV
coefficients on the camera; the people's keypoints are undistorted by it before they check the lines.

Each quantity is the inverse-variance mean of its sources (:mod:`platypose.lifting.calibration.fusion`), a source
more than 3 sigma off the others dropped (of two, the less trusted) and said so once, in the log and in
``meta["camera"]``. Roll and pitch: the scene's vertical vanishing point, then the people standing
(:mod:`platypose.lifting.calibration.people_vertical`; a check on the lines, never the only roll: without the lines
the fallback below is used). Focal length, in this order of trust: the video's metadata
(:func:`platypose.lifting.calibration.lens.metadata_focal`, 5 %), the two horizontal vanishing points
(:func:`platypose.lifting.calibration.scene.estimate.scene_camera`), else the lens prior (said once: "focal length
not measured"); the lines' pitch is moved to the focal length chosen. Where the scene gives nothing (no line detector,
no lines, a moving camera) the lift assumes what it always did: a level camera at the origin with the field-of-view
prior (:func:`platypose.lifting.calibration.defaults.default_camera`), its floor's pitch searched under the people.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from platypose.lifting.calibration.defaults import default_camera
from platypose.lifting.calibration.fusion import Estimate, Fused, fuse
from platypose.lifting.calibration.lens import METADATA, PRIOR, prior_focal
from platypose.lifting.calibration.people_vertical import MIN_FRAMES, PeopleVertical, people_vertical
from platypose.lifting.calibration.people_vertical import SOURCE as PEOPLE
from platypose.lifting.calibration.pose_above_floor import pitched, posed_camera
from platypose.lifting.calibration.scene.distortion import NONE_SEEN as LENS_NONE
from platypose.lifting.calibration.scene.distortion import SOURCE as LENS_SOURCE
from platypose.lifting.calibration.scene.distortion import opencv_coefficients, undistort_pixels
from platypose.lifting.calibration.scene.estimate import FOCAL_HELD_SD, SceneCamera
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
    name: str,
    size: tuple[int, int],
    scene: SceneCamera,
    metadata_focal: float | None = None,
    people: tuple[np.ndarray, np.ndarray] | None = None,
) -> AssumedCamera:
    """The camera of view ``name`` (image ``size`` (height, width)) from its ``scene`` estimate, the focal length of the
    video's metadata where it has one (``metadata_focal`` px) and its ``people`` (keypoints (T, P, 17, 3) and their
    times (T,) s; optional) as a check on the lines' roll and pitch: each quantity the inverse-variance mean of its
    sources (:func:`platypose.lifting.calibration.fusion.fuse`), a source more than 3 sigma off the others dropped and
    said so once. The lines' pitch is taken at the fused focal length."""
    if scene.problem is not None:
        return fallback_camera(name, size, scene.problem)
    focals = [Estimate(metadata_focal, FOCAL_HELD_SD * metadata_focal, METADATA)] if metadata_focal else []
    if scene.focal_px is not None:
        focals.append(Estimate(scene.focal_px, scene.sd["focal_px"], scene.source["focal_px"]))
    focal = fuse(focals, " px") if focals else None
    focal_px = prior_focal(size) if focal is None else focal.value
    at = scene.focal_at if scene.focal_at is not None else focal_px
    scene_pitch = scene.pitch_deg + scene.pitch_slope * float(np.log(focal_px / at))
    pitches = [Estimate(scene_pitch, scene.sd["pitch_deg"], scene.source["pitch_deg"])]
    rolls = [Estimate(scene.roll_deg, scene.sd["roll_deg"], scene.source["roll_deg"])]
    if people is not None and scene.distortion != 0.0:
        keypoints = np.array(people[0], np.float64)
        keypoints[..., :2] = undistort_pixels(keypoints[..., :2], size, scene.distortion)
        people = (keypoints, people[1])
    upright = None if people is None else people_vertical(*people, size, focal_px, (scene_pitch, scene.roll_deg))
    if upright is not None:
        rolls.append(Estimate(upright.roll_deg, upright.sd["roll_deg"], PEOPLE))
        if upright.pitch_deg is not None:
            pitches.append(Estimate(upright.pitch_deg, upright.sd["pitch_deg"], PEOPLE))
    roll, pitch = fuse(rolls, " degrees"), fuse(pitches, " degrees")
    lens = opencv_coefficients(scene.distortion, size, focal_px)  # the camera's, as OpenCV models it
    record = {
        "roll_deg": _entry(roll),
        "pitch_deg": _entry(pitch),
        "focal_px": _entry(focal) if focal else {"value": focal_px, "sd": None, "source": PRIOR},
        "height_m": {"source": HEIGHT_SOURCE},
        "distortion": _distortion(scene.distortion, lens),
        "segments": scene.segments,
        "people": {"note": "no people given"} if people is None else _people(upright),
    }
    focal_text = f"{focal_px:.0f} px" + ("" if focal is None else f" +- {focal.sd:.0f}")
    lines = [
        f"camera from the scene's lines ({scene.segments} segments): rolled {roll.value:.1f} +- {roll.sd:.1f} "
        f"degrees ({roll.source}), {pitched(pitch.value, pitch.sd)} ({pitch.source}); focal length {focal_text} "
        f"({PRIOR if focal is None else focal.source}); height from the {HEIGHT_SOURCE}; "
        + (LENS_NONE if scene.distortion == 0.0 else f"lens distortion k = {scene.distortion:+.2f} ({LENS_SOURCE})")
    ]
    if focal is None and scene.focal_note is not None:
        record["focal_note"] = scene.focal_note
        lines.append(f"{scene.focal_note}; the {PRIOR} is used")
    for quantity, fused in (("roll", roll), ("pitch", pitch), ("focal length", focal)):
        for dropped, why in fused.dropped if fused else ():
            lines.append(f"{quantity}: {dropped.source} ({dropped.value:.1f} +- {dropped.sd:.1f}) dropped: {why}")
    camera = replace(posed_camera(name, size, focal_px, pitch.value, roll.value, 0.0), dist=lens)
    return AssumedCamera(camera, True, record, tuple(lines))


def _distortion(k: float, coefficients: np.ndarray) -> dict:
    """The lens distortion for ``meta["camera"]``: the division model's ``k`` and the camera's OpenCV
    ``coefficients`` (8)."""
    if k == 0.0:
        return {"value": 0.0, "source": LENS_NONE, "opencv": [0.0] * 5}
    return {
        "value": k,
        "model": "division: undistorted = distorted / (1 + k r^2), r over half the image diagonal",
        "source": LENS_SOURCE,
        "opencv": coefficients.tolist(),
    }


def _entry(fused: Fused) -> dict:
    """A fused quantity for ``meta["camera"]``: value, sd, source (the used ones joined), each source used and
    each dropped with why."""
    return {
        "value": float(fused.value),
        "sd": float(fused.sd),
        "source": fused.source,
        "used": [e.as_dict() for e in fused.used],
        "dropped": [{**e.as_dict(), "why": why} for e, why in fused.dropped],
    }


def _people(people: PeopleVertical | None) -> dict:
    """What the people's verticals measured, for ``meta["camera"]``."""
    if people is None:
        return {"note": f"fewer than {MIN_FRAMES} person-frames stand still on a straight leg: not used"}
    return {"frames": people.frames, "persons": people.persons, "pitch_measured": people.pitch_deg is not None}
