"""The world's up as the people in view show it: roll and pitch at a given focal length, a check on the scene's lines.

A person standing still holds their centre of mass over their support, so in a frame where they stand still (their
hips moving under ``STILL_PER_S`` of their support-to-hips length a second: a walker's centre of mass runs ahead of
the foot on the ground, up to 15 degrees) on a straight leg the line from the support (the ankles' midpoint, or the
straight leg's ankle when the other leg is bent or lifted) to the hips' midpoint (near the centre of mass) is
upright and points at the vertical vanishing point. The
camera's pitch and roll at a given focal length are those whose vertical vanishing point those lines point at
best (robust least squares on the sine of each line's miss). People lean, sway and stand in their own ways, so
each person's lines share an unknown lean of ``LEAN_SD_DEG``: the standard deviations are those of generalised
least squares with that lean common to a person's frames and the lines' own scatter about it independent. One
person in one place measures the roll (the direction of up there) and hardly the pitch (where lines converge):
its spread says so, and where the pitch is not measured (a spread over ``PITCH_MEASURED_SD_DEG``, or a fit ending at
a bound: a camera looking up 25 degrees) it is None. The roll is always the one at the given pitch (the lines'):
a check of the lines' roll that the people's less sure pitch does not move.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from platypose.lifting.calibration.pose_above_floor import rotation
from platypose.lifting.calibration.scene.lines import Lines, image_scale, to_lines, vanishing_point
from platypose.lifting.skeleton import JOINT_INDEX

SOURCE = "people (support-to-hips lines of standing frames)"
MIN_CONFIDENCE = 0.3
STILL_PER_S = 0.5  # hips moving under this share of the support-to-hips length a second: standing still
STILL_WINDOW_S = 0.5  # over this time about a frame
STRAIGHT_DEG = 20.0  # a leg bent less than this at the knee (in the image) is straight
MAX_TILT_DEG = 45.0  # a standing person's line within this of the image's up (as the scene's upright edges)
MIN_FRAMES, MAX_FRAMES = 20, 400  # standing person-frames needed; fitted at most (evenly spaced over the take)
LEAN_SD_DEG = 2.0  # a person's support-to-hips line off the world's up, the same over their frames
MIN_SCATTER_DEG = 0.5  # the floor of a line's own scatter about its person's lean (keypoints' noise)
MAX_SD_DEG = 90.0  # a spread past this is "not measured" all the same
PITCH_MEASURED_SD_DEG = 10.0  # a wider pitch is not measured: the roll is fitted again with the pitch held
STEP = 1e-6  # radians: the Jacobian's central differences
BOUNDS_DEG = ((-25.0, -40.0), (89.0, 40.0))  # pitch, roll: as the scene's vertical vanishing point

_LEGS = [(JOINT_INDEX[f"{s}_hip"], JOINT_INDEX[f"{s}_knee"], JOINT_INDEX[f"{s}_ankle"]) for s in ("right", "left")]
_ANKLES = [JOINT_INDEX["right_ankle"], JOINT_INDEX["left_ankle"]]
_HIPS = [JOINT_INDEX["right_hip"], JOINT_INDEX["left_hip"]]


@dataclass(frozen=True)
class PeopleVertical:
    """Pitch (None: not measured) and roll (degrees) at the given focal length, their standard deviations
    (``sd``: ``pitch_deg`` where measured, ``roll_deg``), and the standing person-frames and persons they came
    from."""

    pitch_deg: float | None
    roll_deg: float
    sd: dict[str, float]
    frames: int
    persons: int


def _angle(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Degrees (N,) between 2D vectors ``a`` and ``b`` (N, 2)."""
    cos = (a * b).sum(-1) / np.maximum(np.linalg.norm(a, axis=-1) * np.linalg.norm(b, axis=-1), 1e-12)
    return np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))


def standing_lines(keypoints: np.ndarray, times: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The support-to-hips segments (N, 4) px (the support first) of the person-frames of ``keypoints``
    (T, P, 17, 3) on ``times`` (T,) s standing still (:func:`hips_speed`) on a straight leg and upright in the
    image, and each one's person (N,). A frame where the hips are not seen at either end of the window about it is
    not known to be still."""
    k = np.array(keypoints, np.float64)
    k[..., :2][~(np.nan_to_num(k[..., 2]) >= MIN_CONFIDENCE)] = np.nan
    xy = k[..., :2]
    with np.errstate(invalid="ignore"):
        straight = np.stack(
            [
                180.0 - _angle(xy[..., hip, :] - xy[..., knee, :], xy[..., ankle, :] - xy[..., knee, :]) < STRAIGHT_DEG
                for hip, knee, ankle in _LEGS
            ],
            axis=-1,
        )  # (T, P, 2): right, left
        ankles = xy[..., _ANKLES, :]
        one = np.where(straight[..., :1], ankles[..., 0, :], ankles[..., 1, :])
        support = np.where(straight.all(-1, keepdims=True), ankles.mean(-2), one)
        hips = xy[..., _HIPS, :].mean(-2)
        up = hips - support
        length = np.linalg.norm(up, axis=-1)
        standing = straight.any(-1) & (-up[..., 1] >= np.cos(np.radians(MAX_TILT_DEG)) * length)
        standing &= hips_speed(hips, times) < STILL_PER_S * length
    frame, person = np.nonzero(standing)
    segments = np.concatenate([support[frame, person], hips[frame, person]], axis=-1)
    if len(segments) > MAX_FRAMES:
        keep = np.linspace(0, len(segments) - 1, MAX_FRAMES).round().astype(int)
        segments, person = segments[keep], person[keep]
    return segments, person


def hips_speed(hips: np.ndarray, times: np.ndarray) -> np.ndarray:
    """Pixels a second (T, P) the hips ``hips`` (T, P, 2) on ``times`` (T,) s move over ``STILL_WINDOW_S`` about each
    frame (keypoints' jitter averaged out); NaN where either end does not see them or the take is shorter."""
    times = np.asarray(times, np.float64)
    before = np.searchsorted(times, times - STILL_WINDOW_S / 2.0)
    after = np.clip(np.searchsorted(times, times + STILL_WINDOW_S / 2.0, side="right") - 1, 0, len(times) - 1)
    span = times[after] - times[before]
    with np.errstate(invalid="ignore", divide="ignore"):
        speed = np.linalg.norm(hips[after] - hips[before], axis=-1) / span[:, None]
    return np.where((span > 0)[:, None], speed, np.nan)


def _point(params: np.ndarray, focal: float) -> np.ndarray:
    """The vertical vanishing point (3,) (normalised) of a camera pitched and rolled ``params`` (radians)."""
    up = rotation(*np.degrees(params))[:, 2]
    return vanishing_point(up, focal)


def _residuals(params: np.ndarray, lines: Lines, focal: float) -> np.ndarray:
    """Each line's signed miss (N,): the sine of its angle off the direction to the vanishing point."""
    point = _point(params, focal)
    towards = point[:2] - point[2] * lines.middle
    norm = np.maximum(np.linalg.norm(towards, axis=-1), 1e-12)
    sign = np.sign((towards * lines.direction).sum(-1))  # the line runs up: the point is ahead or behind it
    return sign * (lines.direction[:, 0] * towards[:, 1] - lines.direction[:, 1] * towards[:, 0]) / norm


def spreads(jacobian: np.ndarray, residuals: np.ndarray, person: np.ndarray) -> np.ndarray:
    """Standard deviations (2,) of the fitted (pitch, roll) (radians) from the ``jacobian`` (N, 2) of the lines'
    misses (a held parameter's column zero), the misses (N,) and each line's person (N,): generalised least squares
    where each person's lines share a lean (``LEAN_SD_DEG``, or the spread of the persons' median misses where two
    or more disagree more) and scatter about it independently (their robust spread about their median); a direction
    the lines do not fix (or a held parameter) comes out at ``MAX_SD_DEG``."""
    persons = np.unique(person)
    medians = np.array([np.median(residuals[person == p]) for p in persons])
    lean = np.sin(np.radians(LEAN_SD_DEG)) ** 2
    if len(persons) >= 2:  # people who disagree more than the prior's lean: their own spread
        lean = max(lean, float(np.var(medians, ddof=1)))
    centred = residuals - medians[np.searchsorted(persons, person)]
    scatter = max(1.4826 * float(np.median(np.abs(centred))), np.sin(np.radians(MIN_SCATTER_DEG))) ** 2
    information = np.zeros((2, 2))
    for p in persons:
        rows = jacobian[person == p]
        sums = rows.sum(axis=0)
        information += (rows.T @ rows - lean / (scatter + len(rows) * lean) * np.outer(sums, sums)) / scatter
    covariance = np.linalg.inv(information + np.eye(2) / np.radians(MAX_SD_DEG) ** 2)  # a flat direction: MAX_SD
    return np.sqrt(np.clip(np.diag(covariance), 0.0, None))


def _fit(lines: Lines, focal: float, start: np.ndarray, free: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The robust least-squares fit of the parameters ``free`` (2,) of (pitch, roll) (radians) from ``start``,
    the others held: the fitted (2,), the misses (N,) and their Jacobian (N, 2) (zero for a held one)."""
    low, high = np.radians(BOUNDS_DEG[0]), np.radians(BOUNDS_DEG[1])
    start = np.clip(start, low + 1e-6, high - 1e-6)

    def misses(x: np.ndarray) -> np.ndarray:
        full = start.copy()
        full[free] = x
        return _residuals(full, lines, focal)

    fitted = least_squares(
        misses,
        start[free],
        bounds=(low[free], high[free]),
        loss="soft_l1",
        f_scale=np.sin(np.radians(3.0)),
        x_scale=1.0,
    )
    params, jacobian = start.copy(), np.zeros((len(lines), 2))
    params[free] = fitted.x
    for k in np.nonzero(free)[0]:  # the misses' own Jacobian: the robust loss's weights are not a model of them
        step = np.zeros(2)
        step[k] = STEP
        jacobian[:, k] = (_residuals(params + step, lines, focal) - _residuals(params - step, lines, focal)) / (
            2 * STEP
        )
    return params, fitted.fun, jacobian


def people_vertical(
    keypoints: np.ndarray,
    times: np.ndarray,
    size: tuple[int, int],
    focal_px: float,
    start_deg: tuple[float, float] = (10.0, 0.0),
) -> PeopleVertical | None:
    """The pitch and roll at ``focal_px`` that the people of ``keypoints`` (T, P, 17, 3) on ``times`` (T,) s in an
    image of ``size`` (height, width) show standing still. The roll is the one at the pitch of ``start_deg``
    (pitch, roll: the scene's), the check of the lines' roll: a person off the image's middle ties the two together,
    and the people's pitch is the less sure. The pitch is fitted with the roll; where the lines do not fix it (the
    fit ends at a bound, or its spread is over ``PITCH_MEASURED_SD_DEG``: one place gives one direction of up)
    ``pitch_deg`` is None. None where fewer than ``MIN_FRAMES`` person-frames stand still."""
    segments, person = standing_lines(keypoints, times)
    if len(segments) < MIN_FRAMES:
        return None
    lines = to_lines(segments, size)
    focal = focal_px / image_scale(size)
    start = np.radians(np.asarray(start_deg, np.float64))
    both, misses, jacobian = _fit(lines, focal, start, np.array([True, True]))
    pitch_sd = float(np.degrees(spreads(jacobian, misses, person))[0])
    at_bound = np.abs(np.radians(BOUNDS_DEG)[:, 0] - both[0]).min() < np.radians(0.5)
    measured = not at_bound and pitch_sd <= PITCH_MEASURED_SD_DEG
    held, misses, jacobian = _fit(lines, focal, start, np.array([False, True]))
    sd = {"roll_deg": float(np.degrees(spreads(jacobian, misses, person))[1])}
    if measured:
        sd["pitch_deg"] = pitch_sd
    pitch = float(np.degrees(both[0])) if measured else None
    return PeopleVertical(pitch, float(np.degrees(held[1])), sd, len(segments), len(np.unique(person)))
