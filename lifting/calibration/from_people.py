"""The camera from the people it sees: pitch, roll, focal length and height above the floor, from 2D keypoints.

One uncalibrated view. Every person, in every frame where both ankles, the pelvis, the thorax and the neck or head
are seen, is taken as standing upright on one floor: the midpoint of the ankles is ``ANKLE_HEIGHT`` above it, and
the pelvis, thorax, neck and head lie straight above that point at fixed fractions of the person's stature
(``BODY_HEIGHTS``). For a camera (focal length, pitch, roll, height), the ankles' ray meets the floor at the
person's place, and the body's points above it project to predicted pixels; the camera is the one whose
predictions come nearest the keypoints over all persons and frames (robust least squares, each residual in
units of the person's size in the image, so near and far persons count alike). What it uses:

- the lines from ankles to head of upright people meet at the vertical vanishing point (roll and pitch);
- how a person's image size changes with where their feet are in the image (the floor's slope in the image:
  pitch and height over stature; with people at several depths and places, the focal length);
- adult stature, ``STATURE_M`` with a spread of ``STATURE_SD_M`` per person, fixes the scale.

Leaning, bending, jumping, a person on a roof or a step: each residual's loss is soft beyond one person-size
unit, and after a first fit the person-frames off by more than ``REJECT_FACTOR`` times the median (and persons
whose median is) are left out and the fit is redone (RANSAC-like). Each quantity's uncertainty is its standard
deviation over ``BOOTSTRAP`` refits on persons and seconds drawn again with replacement. The focal length is
the people's where the fit's data alone pin it within ``FOCAL_MEASURED_SD`` (relative); else it is held at the
given one (the video's metadata or a lens prior, :mod:`platypose.lifting.calibration.lens`), and said so.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.optimize import least_squares

from platypose.lifting.calibration.pose_above_floor import rotation
from platypose.lifting.stance import ANKLE_HEIGHT, ANKLES

BODY = (0, 8, 9, 10)  # pelvis, thorax, neck, head (lifting.skeleton order), above the point stood on
# their heights as fractions of stature (Drillis & Contini; the head centre at the ears, the neck 30 % of the way
# from it to the thorax as in lifting.joint_maps)
BODY_HEIGHTS = (0.53, 0.818, 0.896, 0.93)
STATURE_M, STATURE_SD_M = 1.70, 0.08  # an adult's stature: the scale
MIN_CONFIDENCE = 0.3
MIN_OBSERVATIONS = 20  # upright person-frames the camera needs
MAX_OBSERVATIONS = 400  # person-frames fitted (evenly spaced over the take)
NOISE = 0.03  # a residual's unit: this share of the person's ankle-to-head length in the image, plus 2 px
REJECT_FACTOR = 3.0
MIN_INLIERS = 0.5  # share of person-frames that must agree with the camera
BOOTSTRAP = 8
START_PITCHES_DEG, START_ROLLS_DEG = (5.0, 25.0, 45.0), (-20.0, 0.0, 20.0)  # the fit starts from each
START_STEPS = 15  # function evaluations from each start before the best one is fitted to the end
BOOTSTRAP_STEPS = 30  # and of each bootstrap refit (it starts at the fit; a crawl along a flat valley is cut)
FOCAL_MEASURED_SD = 0.04  # the people measure the focal length when its relative sd from their data is under this
MAX_PITCH_SD_DEG, MAX_ROLL_SD_DEG = 6.0, 6.0  # wider spreads: the cues disagree
FOCAL_PRIOR_SD = 0.3  # log focal: how far the lens prior lets the people move it in the first fit


@dataclass(frozen=True)
class Observations:
    """Person-frames: ``ankles`` (N, 2) the pixel stood on (the ankles' midpoint), ``body`` (N, 4, 2) px of BODY
    (NaN where not seen), ``person`` (N,), ``second`` (N,) (the whole second of the take they are in), ``size`` (N,)
    the person's stature in px (from the thorax's height over the point stood on)."""

    ankles: np.ndarray
    body: np.ndarray
    person: np.ndarray
    second: np.ndarray
    size: np.ndarray

    def __len__(self) -> int:
        return len(self.ankles)

    def take(self, index: np.ndarray) -> Observations:
        """The observations at ``index``."""
        return Observations(
            self.ankles[index], self.body[index], self.person[index], self.second[index], self.size[index]
        )


@dataclass
class CameraEstimate:
    """What the people say about the camera: values, their standard deviations and how they were found."""

    focal_px: float
    pitch_deg: float
    roll_deg: float
    height_m: float
    sd: dict[str, float]
    focal_source: str  # "people", or the given focal's source (metadata, lens prior)
    observations: int  # person-frames kept
    rejected: int  # person-frames left out as not upright or elsewhere
    persons: int
    problem: str | None = None  # why the estimate should not be used (too few cues, cues disagree)
    statures_m: list[float] = field(default_factory=list)


def observations(keypoints: np.ndarray, times: np.ndarray) -> Observations:
    """The person-frames of ``keypoints`` (T, P, 17, 3) on ``times`` (T,) whose ankles, pelvis, thorax and neck or
    head are seen (a BODY point not seen is NaN)."""
    k = np.array(keypoints, np.float64)
    k[..., :2][np.nan_to_num(k[..., 2]) < MIN_CONFIDENCE] = np.nan
    needed = [*ANKLES, 0, 8]
    seen = np.isfinite(k[..., needed, :2]).all((-1, -2)) & np.isfinite(k[..., [9, 10], 0]).any(-1)
    frame, person = np.nonzero(seen)
    ankles = k[frame, person][:, list(ANKLES), :2].mean(axis=1)
    body = k[frame, person][:, list(BODY), :2]
    size = np.linalg.norm(body[:, 1] - ankles, axis=-1) / (BODY_HEIGHTS[1] - ANKLE_HEIGHT / STATURE_M)
    second = np.floor(np.asarray(times, np.float64)[frame] - float(np.min(times))).astype(np.int64)
    found = Observations(ankles, body, person, second, size)
    keep = size > 10.0  # a person a few pixels tall says nothing
    if keep.sum() > MAX_OBSERVATIONS:
        keep[keep] = np.isin(np.arange(keep.sum()), np.linspace(0, keep.sum() - 1, MAX_OBSERVATIONS).astype(int))
    return found.take(np.nonzero(keep)[0])


def predict(params: np.ndarray, obs: Observations, centre: np.ndarray) -> np.ndarray:
    """Predicted BODY pixels (N, 3, 2) for ``params`` = (log focal, pitch, roll, log height, statures...)."""
    focal, height = np.exp(params[0]), np.exp(params[3])
    R = rotation(np.degrees(params[1]), np.degrees(params[2]))
    rays = np.column_stack([(obs.ankles - centre) / focal, np.ones(len(obs))]) @ R  # world directions (N, 3)
    down = np.minimum(rays[:, 2], -1e-3)  # a ray at or above the horizon meets the floor far away
    places = np.array([0.0, 0.0, height]) + rays * ((ANKLE_HEIGHT - height) / down)[:, None]
    statures = params[4:][obs.person]
    lift = statures[:, None] * (np.array(BODY_HEIGHTS) - ANKLE_HEIGHT / STATURE_M)[None]  # (N, 3)
    points = places[:, None, :] + lift[..., None] * np.array([0.0, 0.0, 1.0])
    cam = (points - np.array([0.0, 0.0, height])) @ R.T
    depth = np.maximum(cam[..., 2:], 1e-3)
    return cam[..., :2] / depth * focal + centre


def _residuals(params, obs, centre, focal_prior, focal_free, persons):
    full = params if focal_free else np.concatenate([[np.log(focal_prior)], params])
    off = np.nan_to_num((predict(full, obs, centre) - obs.body) / (NOISE * obs.size + 2.0)[:, None, None])
    priors = [(full[4:][persons] - STATURE_M) / STATURE_SD_M]
    if focal_free:
        priors.append([(full[0] - np.log(focal_prior)) / FOCAL_PRIOR_SD])
    return np.concatenate([off.ravel(), *[np.ravel(p) for p in priors]])


def _bounds(focal_prior: float, count: int, focal_free: bool) -> tuple[np.ndarray, np.ndarray]:
    low = [np.log(focal_prior / 3.0), np.radians(-45.0), np.radians(-60.0), np.log(0.3), *[1.2] * count]
    high = [np.log(focal_prior * 3.0), np.radians(85.0), np.radians(60.0), np.log(100.0), *[2.2] * count]
    first = 0 if focal_free else 1
    return np.array(low[first:]), np.array(high[first:])


def _fit(obs, centre, focal_prior, start, focal_free, max_nfev=None):
    persons = np.unique(obs.person)
    count = len(start) - 4
    low, high = _bounds(focal_prior, count, focal_free)
    x0 = np.clip(start if focal_free else start[1:], low + 1e-9, high - 1e-9)
    result = least_squares(
        _residuals,
        x0,
        bounds=(low, high),
        args=(obs, centre, focal_prior, focal_free, persons),
        loss="soft_l1",
        f_scale=1.0,
        x_scale="jac",
        max_nfev=max_nfev,
    )
    params = result.x if focal_free else np.concatenate([[np.log(focal_prior)], result.x])
    return params, result


def _starts(focal: float, count: int) -> list[np.ndarray]:
    statures = np.full(count, STATURE_M)
    return [
        np.concatenate([[np.log(focal), np.radians(pitch), np.radians(roll), np.log(height)], statures])
        for pitch in START_PITCHES_DEG
        for roll in START_ROLLS_DEG
        for height in (1.5, 4.0)
    ]


def _off(params, obs, centre) -> np.ndarray:
    """Each person-frame's median residual in its size units (N,)."""
    off = np.linalg.norm(predict(params, obs, centre) - obs.body, axis=-1) / (NOISE * obs.size + 2.0)[:, None]
    return np.nanmedian(off, axis=1)


def _inliers(params, obs, centre) -> np.ndarray:
    off = _off(params, obs, centre)
    limit = REJECT_FACTOR * max(float(np.median(off)), 0.5)
    keep = off <= limit
    for p in np.unique(obs.person):  # a person who stands elsewhere (a roof, a step) as a whole
        mine = obs.person == p
        if np.median(off[mine]) > limit:
            keep &= ~mine
    return keep


def estimate_camera(
    keypoints: np.ndarray,
    times: np.ndarray,
    size: tuple[int, int],
    focal_px: float,
    focal_source: str,
    seed: int = 0,
    hold_focal: bool = False,
) -> CameraEstimate | None:
    """The camera of one view from its people's keypoints (T, P, 17, 3) on ``times`` (T,), image ``size`` (h, w);
    ``focal_px`` (from ``focal_source``) is the focal length used where the people cannot measure it (always with
    ``hold_focal``: a lens the video's metadata names), and the prior the people move it from. None when fewer than ``MIN_OBSERVATIONS`` person-frames are seen upright;
    an estimate with ``problem`` set when they disagree (see the module)."""
    obs = observations(keypoints, times)
    if len(obs) < MIN_OBSERVATIONS:
        return None
    obs = Observations(obs.ankles, obs.body, _relabel(obs), obs.second, obs.size)
    centre = np.array([size[1] / 2.0, size[0] / 2.0])
    count = int(obs.person.max()) + 1
    rough = min(  # a few steps from every start, then the best one to the end
        (_fit(obs, centre, focal_px, start, not hold_focal, START_STEPS) for start in _starts(focal_px, count)),
        key=lambda fitted: fitted[1].cost,
    )
    best = _fit(obs, centre, focal_px, rough[0], not hold_focal)
    keep = _inliers(best[0], obs, centre)
    kept = obs.take(np.nonzero(keep)[0])
    if len(kept) < MIN_OBSERVATIONS:
        kept, keep = obs, np.ones(len(obs), bool)
    measured = False
    if not hold_focal:
        params, _ = _fit(kept, centre, focal_px, best[0], True)
        values = _values(params)
        spread = _bootstrap(kept, centre, focal_px, params, True, seed)
        inside = abs(np.log(values[0] / focal_px)) < np.log(3.0) - 0.05  # a focal length at its bound is not measured
        measured = inside and spread[0] < FOCAL_MEASURED_SD * values[0]
    if not measured:  # the people cannot tell the focal length: hold it at the given one
        params, _ = _fit(kept, centre, focal_px, best[0], False)
        values = _values(params)
        spread = _bootstrap(kept, centre, focal_px, params, False, seed)
    estimate = CameraEstimate(
        focal_px=values[0],
        pitch_deg=values[1],
        roll_deg=values[2],
        height_m=values[3],
        sd=dict(zip(("focal_px", "pitch_deg", "roll_deg", "height_m"), spread)),
        focal_source="people" if measured else focal_source,
        observations=int(keep.sum()),
        rejected=int((~keep).sum()),
        persons=int(len(np.unique(kept.person))),
        statures_m=[float(s) for s in params[4:]],
    )
    estimate.problem = _problem(estimate, len(obs))
    return estimate


def _relabel(obs: Observations) -> np.ndarray:
    """Persons numbered 0..P-1 in order of their ids."""
    return np.unique(obs.person, return_inverse=True)[1].reshape(-1)


def _values(params: np.ndarray) -> list[float]:
    return [
        float(np.exp(params[0])),
        float(np.degrees(params[1])),
        float(np.degrees(params[2])),
        float(np.exp(params[3])),
    ]


def _bootstrap(obs, centre, focal_px, params, focal_free, seed) -> list[float]:
    """Standard deviations of (focal, pitch, roll, height) over refits on person-seconds drawn with replacement."""
    rng = np.random.default_rng(seed)
    blocks = obs.person * 100_000 + obs.second
    labels = np.unique(blocks)
    draws = []
    for _ in range(BOOTSTRAP):
        chosen = rng.choice(labels, size=len(labels), replace=True)
        index = np.concatenate([np.nonzero(blocks == label)[0] for label in chosen])
        refit, _ = _fit(obs.take(index), centre, focal_px, params, focal_free, BOOTSTRAP_STEPS)
        draws.append(_values(refit))
    return [float(v) for v in np.std(np.array(draws), axis=0)]


def _problem(estimate: CameraEstimate, found: int) -> str | None:
    """Why the estimate should not be trusted, or None."""
    if estimate.observations < MIN_INLIERS * found:
        return (
            f"only {estimate.observations} of {found} upright person-frames agree on one camera (people lean, "
            "jump or stand at several levels)"
        )
    if estimate.sd["pitch_deg"] > MAX_PITCH_SD_DEG or estimate.sd["roll_deg"] > MAX_ROLL_SD_DEG:
        return (
            f"the people disagree on the camera's pitch or roll (+-{estimate.sd['pitch_deg']:.1f} and "
            f"+-{estimate.sd['roll_deg']:.1f} degrees over persons and seconds)"
        )
    if not 0.05 < estimate.height_m < 100.0 or not -30.0 < estimate.pitch_deg < 89.0:
        return f"the fit found an implausible camera ({estimate.height_m:.2f} m high, pitched {estimate.pitch_deg:.0f} degrees)"
    return None
