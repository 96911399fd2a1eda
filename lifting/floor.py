"""The floor: a plane in world metres, given (calibration, ``--floor``) or estimated from a lift's foot contacts.

A floor is ``n . x + d = 0`` with ``n`` the unit normal pointing up; ``n . x + d`` is a point's
height above it. Calibrated worlds are Z up with the floor at z = 0 (Pose2Sim, anipose and
mocap systems define them so): ``n = (0, 0, 1)``, ``d = 0``.

Without a calibration (the default camera: level, at the origin) the floor is estimated from a
lift: the stance ankles (the lower ankle of slow frames) of every person's median motion lie on
one plane ``ANKLE_HEIGHT`` above the floor. One view places each ankle on its ray at a depth known
only up to the size prior's scale, which jitters along the ray; a plane fitted to the points
directly would tilt along the rays. So the pitch is the one under which the stance ankles' drops
below the camera agree best in logarithm (a depth scale is a constant there), all persons' ankles
pooled: the size prior gives everyone adult size, so people on one floor drop alike. Each ankle's
disagreement is capped at ``STANDS_ELSEWHERE`` (a person on a roof, a step, or an ankle above the
camera costs that much whatever the pitch, so no pitch is chosen for bringing them onto the floor);
the floor is the lowest level that a fifth of the ankles share (a person on a roof stands higher),
and a weak prior prefers a level camera where the drops cannot tell, as when everyone stays at
about one distance or walks along one image row. Roll is taken as level, and the scale is the size
prior's (an adult of typical size).
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from platypose.lifting.calibration.defaults import NO_EXTRINSICS_NOTE
from platypose.lifting.camera import Camera
from platypose.lifting.settings.choices import FloorChoice, GivenPlane, check_plane, read_floor
from platypose.lifting.stance import ANKLE_HEIGHT, ANKLES, STANCE_SPEED, lower_ankles

LEVEL_PRIOR = 1e-3  # weight of a pitch of 10 degrees against the capped log drops' variance (one view: often flat)
STANDS_ELSEWHERE = np.log(1.3)  # a stance ankle dropping 30 % more or less than the floor level stands elsewhere
SHARED = 0.2  # share of the stance ankles that the floor's level must hold
MIN_DROP = 0.05  # metres: a stance ankle must be this far below the camera to count


@dataclass(frozen=True)
class Floor:
    """The plane ``normal . x + offset = 0`` (``normal`` unit, up), where it came from, and what its estimate found
    (``found``: the camera's height and pitch above it and the stance points used; empty for a floor given)."""

    normal: tuple[float, float, float]
    offset: float
    source: str
    found: dict = field(default_factory=dict, compare=False)

    def height(self, points: np.ndarray) -> np.ndarray:
        """Heights above the floor of points ``(..., 3)``, ``(...)``."""
        return np.asarray(points) @ np.asarray(self.normal) + self.offset

    @property
    def plane(self) -> tuple[float, float, float, float]:
        """``(nx, ny, nz, d)``."""
        return (*self.normal, self.offset)

    def as_dict(self) -> dict:
        """The floor's entry in a result's ``meta``, plain for JSON: normal, offset (m), source, and what its
        estimate found."""
        return {"normal": list(self.normal), "offset_m": self.offset, "source": self.source, **self.found}


@dataclass(frozen=True)
class FloorToEstimate:
    """The floor of a one-camera take, not known before its lift: estimated under a quick lift
    (:func:`platypose.lifting.tracks.quick_floor.quick_floor`). ``height_only``: the camera's roll and pitch are
    known (the scene's lines), so only the floor's height is estimated."""

    height_only: bool = False


def plane_floor(nx: float, ny: float, nz: float, d: float, source: str) -> Floor:
    """The floor ``n . x + d = 0`` with ``n`` scaled to unit length; ValueError for a zero normal."""
    check_plane(nx, ny, nz, d)
    normal = np.array([nx, ny, nz], dtype=np.float64)
    length = float(np.linalg.norm(normal))
    return Floor(tuple(float(v) for v in normal / length), float(d) / length, source)


def given_floor(choice: FloorChoice) -> Floor | str | None:
    """The Floor of a :class:`~platypose.lifting.settings.choices.GivenPlane` (source "given"), "auto" and None as
    they are."""
    if isinstance(choice, GivenPlane):
        return plane_floor(choice.nx, choice.ny, choice.nz, choice.d, "given")
    return choice


def parse_floor(text: str) -> Floor | str | None:
    """A floor specification (:func:`~platypose.lifting.settings.choices.read_floor`): "auto" (returned as is),
    "none" (None), "z=H" or "nx,ny,nz,d" (a Floor); InputError otherwise."""
    return given_floor(read_floor(text))


CALIBRATED_FLOOR = Floor((0.0, 0.0, 1.0), 0.0, "calibration")


def floor_for_lift(choice: FloorChoice, calibration_meta: dict | None) -> Floor | FloorToEstimate | None:
    """The floor a lift uses for the user's ``choice`` (:func:`~platypose.lifting.settings.choices.read_floor` of
    ``--floor``, kept by ``TakeSettings.floor_choice``): a given plane as a Floor, None for none, and for "auto" the
    calibration's z = 0 when its cameras are placed in a world (``calibration_meta`` of a file whose extrinsics were
    all given), else :class:`FloorToEstimate` (no calibration, or cameras at the default pose). The Floor returned
    is the one object the take's sampler and finishing use (``platypose.pipeline.lift_take``), so its source is the
    user's choice."""
    if choice != "auto":
        return given_floor(choice)
    if calibration_meta is None:
        return FloorToEstimate()
    assumptions = " ".join(calibration_meta.get("assumptions", []))
    return FloorToEstimate() if NO_EXTRINSICS_NOTE in assumptions else CALIBRATED_FLOOR


def stance_points(joints: np.ndarray, fps: float, seen: np.ndarray | None = None) -> list[np.ndarray]:
    """Stance ankles ``(M_p, 3)`` of each person's motion ``(P, T, 17, 3)``: per frame the lower ankle along world
    z (:func:`platypose.lifting.stance.lower_ankles`, the right one on a tie), if it moves slower than
    ``STANCE_SPEED``; frames with missing joints, or not ``seen`` ``(P, T)``, are skipped."""
    points = []
    for p, person in enumerate(joints):
        ankles = person[:, list(ANKLES)]  # (T, 2, 3)
        if len(ankles) < 2:
            continue
        speed = np.linalg.norm(np.gradient(ankles, axis=0), axis=-1) * fps  # (T, 2)
        lower = np.argmax(lower_ankles(ankles[..., 2]), axis=1)
        frames = np.arange(len(ankles))
        chosen, chosen_speed = ankles[frames, lower], speed[frames, lower]
        keep = np.isfinite(chosen).all(-1) & (chosen_speed < STANCE_SPEED)
        if seen is not None:
            keep &= seen[p]
        points.append(chosen[keep])
    return points


def estimate_floor(
    joints: np.ndarray, camera: Camera, fps: float, seen: np.ndarray | None = None, pitch_range_deg: float = 30.0
) -> Floor | None:
    """The floor under median motions ``(P, T, 17, 3)`` lifted with the level default ``camera`` (see the module),
    with what was found (``Floor.found``): camera height above it (m), pitch (degrees, positive looking down), stance
    points used.
    ``seen`` ``(P, T)``: the frames whose ankles the camera saw (the others' rays are the prior's guess).

    None when fewer than 10 stance ankles are found below the camera.
    """
    points = np.concatenate([np.zeros((0, 3)), *stance_points(joints, fps, seen)])
    center = camera.center
    up = np.array([0.0, 0.0, 1.0])
    toward = np.cross(camera.R[0], up)  # pitch turns the world's up about the camera's x axis
    best = None
    for pitch in np.deg2rad(np.arange(-pitch_range_deg, pitch_range_deg + 0.125, 0.25)):
        normal = np.cos(pitch) * up + np.sin(pitch) * toward
        drops = (center - points) @ normal  # stance ankles below the camera
        below = drops > MIN_DROP
        if below.sum() < 10:
            continue
        # one view gets depth (and so each drop) only up to a scale that jitters along the rays: compare logs
        logs = np.log(drops[below])
        level = _lowest_shared_height(-logs, SHARED, band=STANDS_ELSEWHERE / 2)
        off = np.full(len(points), STANDS_ELSEWHERE)
        off[below] = np.minimum(np.abs(logs + level), STANDS_ELSEWHERE)
        score = np.mean(off**2) + LEVEL_PRIOR * (pitch / np.deg2rad(10.0)) ** 2  # most cameras are near level
        if best is None or score < best[0]:
            best = (score, pitch, normal, drops[below])
    if best is None:
        return None
    _, pitch, normal, drops = best
    level = _lowest_shared_height(-drops, SHARED)  # stance ankles' height relative to the camera
    offset = -(center @ normal) - (level - ANKLE_HEIGHT)  # so that stance ankles stand ANKLE_HEIGHT above it
    floor = Floor(tuple(float(v) for v in normal), float(offset), "estimated")
    camera_height = float(floor.height(center))
    down_pitch = float(np.degrees(np.arcsin(np.clip(camera.R[2] @ -np.asarray(normal), -1, 1))))
    found = {"camera_height_m": camera_height, "camera_pitch_deg": down_pitch, "stance_points": int(len(drops))}
    return replace(floor, found=found)


def _lowest_shared_height(heights: np.ndarray, share: float, band: float = 0.05) -> float:
    """The lowest height that at least ``share`` of ``heights`` lie within ``band`` of (median of those)."""
    ordered = np.sort(heights)
    need = max(1, int(np.ceil(share * len(ordered))))
    for value in ordered:
        near = ordered[np.abs(ordered - value) <= band]
        if len(near) >= need:
            return float(np.median(near))
    return float(np.median(ordered))


def floor_under(
    median: np.ndarray, camera: Camera, fps: float, keypoints: np.ndarray, height_only: bool = False
) -> Floor | None:
    """The floor estimated under the median motions ``(P, T, 17, 3)`` lifted with one default ``camera``, where
    it saw both ankles (``keypoints`` ``(T, P, 17, 3)``), with the camera's height and pitch above it; None when
    too few stance ankles are found. ``height_only``: the camera's roll and pitch in its z-up world are known (the
    scene's lines), so the floor is level there and only its height is estimated."""
    seen = (np.nan_to_num(keypoints[..., list(ANKLES), 2]) > 0).all(axis=-1).T  # (P, T)
    return estimate_floor(
        np.asarray(median, dtype=np.float64), camera, fps, seen, pitch_range_deg=0.0 if height_only else 30.0
    )
