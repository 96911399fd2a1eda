"""Two horizontal directions at right angles to each other and to the vertical, and the focal length they give.

Given the vertical vanishing point, each focal length fixes the world's up in the camera and so the horizon;
each yaw on it fixes two orthogonal horizontal directions and their vanishing points. The search scores a grid
of (focal length, yaw) by the length of the non-vertical segments pointing at either point (as
:func:`platypose.lifting.calibration.scene.vertical.score`), then the camera (pitch, roll, yaw, focal length) is
fitted to the segments of all three directions by robust least squares (each residual the sine of a segment's
angle off its point, over the tolerance, weighted by length). The standard deviations come from the fit's
Jacobian, so a focal length the lines cannot fix (a horizontal point at infinity: a wall seen square on) shows
as a wide one.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.optimize import least_squares

from platypose.lifting.calibration.pose_above_floor import pitch_roll, rotation
from platypose.lifting.calibration.scene.lines import (
    Lines,
    direction_of,
    misalignment,
    misalignment_each,
    vanishing_point,
)
from platypose.lifting.calibration.scene.vertical import unlikeliness

TOLERANCE_DEG = 1.5  # the fit's unit
SEARCH_TOLERANCE_DEG = 3.0  # the grid's: wide enough for a vertical point a little off
FOCAL_STEPS, YAW_STEP_DEG = 60, 1.0
SEARCH_LINES = 250
LABEL_TOLERANCE_DEG = 2.0  # a segment belongs to the direction whose point it misses by less than this
MIN_SEGMENTS = 4  # a horizontal direction needs this many segments to count
LOG_FOCAL_BOUND = 10.0  # normalised focal lengths beyond exp(+-10) are no camera's


@dataclass(frozen=True)
class Fit:
    """A camera fitted to labelled lines: ``params`` (pitch, roll, yaw in radians, log focal), their standard
    deviations ``sd`` (4,) (focal's NaN where held), and each line's ``labels`` (N,): 0 and 1 the horizontal
    directions, 2 the vertical, -1 none."""

    params: np.ndarray
    sd: np.ndarray
    labels: np.ndarray

    @property
    def focal(self) -> float:
        """The focal length in normalised units."""
        return float(np.exp(self.params[3]))


def camera_rotation(params: np.ndarray) -> np.ndarray:
    """World-to-camera rotation (3, 3) of (pitch, roll, yaw) radians: the world's x, y, z are its columns."""
    c, s = np.cos(params[2]), np.sin(params[2])
    yaw = np.array([[c, -s, 0.0], [s, c, 0.0], [0.0, 0.0, 1.0]])
    return rotation(np.degrees(params[0]), np.degrees(params[1])) @ yaw


def points_of(params: np.ndarray) -> np.ndarray:
    """The vanishing points (3, 3) of the world's x, y and z (rows) for ``params`` (a log focal length past
    ``LOG_FOCAL_BOUND``, which a least-squares trial step on a degenerate set can take, is held there)."""
    log_focal = float(np.clip(params[3], -LOG_FOCAL_BOUND, LOG_FOCAL_BOUND))
    return vanishing_point(camera_rotation(params).T, float(np.exp(log_focal)))


def _horizontal_pairs(vertical: np.ndarray, focal: float, yaws: np.ndarray) -> np.ndarray:
    """The vanishing points (2, Y, 3) of the two horizontal directions at each yaw for this focal length."""
    up = direction_of(vertical, focal)
    a = np.array([1.0, 0.0, 0.0]) - up[0] * up
    a /= np.linalg.norm(a)
    b = np.cross(up, a)
    c, s = np.cos(yaws)[:, None], np.sin(yaws)[:, None]
    return np.stack([vanishing_point(c * a + s * b, focal), vanishing_point(c * b - s * a, focal)])


def search(lines: Lines, vertical: np.ndarray, focal_range: tuple[float, float]) -> np.ndarray:
    """The best (pitch, roll, yaw, log focal) on the grid for ``lines`` not explained by the ``vertical`` point
    (the ``SEARCH_LINES`` longest of them: the fit that follows uses all)."""
    lines = lines.take(np.argsort(-lines.length)[:SEARCH_LINES])
    focals = np.geomspace(*focal_range, FOCAL_STEPS)
    yaws = np.radians(np.arange(0.0, 90.0, YAW_STEP_DEG))
    tol = np.sin(np.radians(SEARCH_TOLERANCE_DEG))
    best, where = -1.0, (focals[0], 0.0)
    for focal in focals:
        pairs = _horizontal_pairs(vertical, focal, yaws)
        weight = np.clip(1.0 - (misalignment(lines, pairs) / tol) ** 2, 0.0, None).max(axis=0)
        scores = weight @ lines.length
        if scores.max() > best:
            best, where = float(scores.max()), (focal, yaws[int(np.argmax(scores))])
    return params_of(vertical, *where)


def params_of(vertical: np.ndarray, focal: float, yaw_on_horizon: float) -> np.ndarray:
    """(pitch, roll, yaw, log focal) of the camera whose first horizontal direction is at ``yaw_on_horizon``."""
    first = _horizontal_pairs(vertical, focal, np.array([yaw_on_horizon]))[0, 0]
    return _params(direction_of(vertical, focal), np.array([first[0] / focal, first[1] / focal, first[2]]), focal)


def _params(up: np.ndarray, x: np.ndarray, focal: float) -> np.ndarray:
    """(pitch, roll, yaw, log focal) of the camera seeing the world's up and x as ``up`` and ``x`` (3,)."""
    x = x / np.linalg.norm(x)
    pitch, roll = np.radians(pitch_roll(up))
    turn = rotation(np.degrees(pitch), np.degrees(roll)).T @ np.column_stack([x, np.cross(up, x), up])
    return np.array([pitch, roll, np.arctan2(turn[1, 0], turn[0, 0]), np.log(focal)])


def upright(params: np.ndarray) -> np.ndarray:
    """The same three directions with the world's up the one of them that makes the likeliest camera
    (:func:`platypose.lifting.calibration.scene.vertical.unlikeliness`): a floor's edges running away from a
    camera can look as upright in the image as the walls' and meet above it, and the three directions of a
    square scene explain the lines equally in any order."""
    axes = camera_rotation(params).T  # the world's x, y, z in camera coordinates (rows)
    axes = np.where(axes[:, 1:2] > 0, -axes, axes)  # each pointing up the image
    costs = [unlikeliness(*pitch_roll(axis)) for axis in axes]
    best = int(np.argmin(costs))
    if best == 2:
        return params
    return _params(axes[best], axes[2], float(np.exp(params[3])))


def solve(lines: Lines, vertical: np.ndarray, inliers: np.ndarray, focal_range: tuple[float, float]) -> Fit:
    """The camera fitted to ``lines`` from the grid's best start for the ``vertical`` point (the lines not among
    its ``inliers`` (N,) searched for the horizontal directions), the world's up then the likeliest direction."""
    fitted = refit(lines, search(lines.take(~inliers), vertical, focal_range))
    turned = upright(fitted.params)
    return fitted if turned is fitted.params else refit(lines, turned)


def refit(lines: Lines, start: np.ndarray, counts: np.ndarray | None = None) -> Fit:
    """The camera fitted to ``lines`` (each weighted by ``counts`` (N,), default 1) labelled at ``start``, then
    fitted again to the lines its result labels."""
    fitted = fit(lines, label(lines, start), start, counts=counts)
    return fit(lines, fitted.labels, fitted.params, counts=counts)


def explained(lines: Lines, params: np.ndarray, counts: np.ndarray | None = None) -> float:
    """The length of ``lines`` (each times ``counts``, default 1) the camera ``params`` explains: each line's
    length times ``1 - (err / tol)^2`` for the nearest of its three vanishing points, ``LABEL_TOLERANCE_DEG``."""
    err = misalignment(lines, points_of(params)).min(axis=0) / np.sin(np.radians(LABEL_TOLERANCE_DEG))
    weight = np.clip(1.0 - err**2, 0.0, None) * lines.length
    return float(weight.sum() if counts is None else weight @ counts)


def label(lines: Lines, params: np.ndarray) -> np.ndarray:
    """Each line's direction (N,): the index (0, 1, 2) of the point it misses least, -1 past the tolerance."""
    err = misalignment(lines, points_of(params))
    labels = np.argmin(err, axis=0)
    return np.where(err.min(axis=0) < np.sin(np.radians(LABEL_TOLERANCE_DEG)), labels, -1)


def _residuals(free, lines, labels, weights, held_focal):
    params = np.append(free, np.log(held_focal)) if held_focal is not None else free
    return weights * misalignment_each(lines, points_of(params)[labels])


def fit(
    lines: Lines,
    labels: np.ndarray,
    start: np.ndarray,
    held_focal: float | None = None,
    counts: np.ndarray | None = None,
) -> Fit:
    """The camera fitted to the labelled ``lines`` from ``start``; with ``held_focal`` (normalised) the focal
    length is held there and only the vertical's lines are used (wrong focal length, wrong horizon). ``counts``
    (N,) weighs each line as that many copies (a bootstrap's draw; default 1)."""
    use = labels == 2 if held_focal is not None else labels >= 0
    if counts is not None:
        use &= counts > 0
    chosen, chosen_labels = lines.take(use), labels[use]
    copies = np.ones(len(chosen)) if counts is None else counts[use]
    weights = np.sqrt(copies * chosen.length / chosen.length.mean()) / np.sin(np.radians(TOLERANCE_DEG))
    free = start[:3] if held_focal is not None else start
    result = least_squares(
        _residuals, free, args=(chosen, chosen_labels, weights, held_focal), loss="soft_l1", x_scale=1.0
    )
    sd = _standard_deviations(result, len(free))
    params = np.append(result.x, np.log(held_focal)) if held_focal is not None else result.x
    if held_focal is not None:
        sd = np.append(sd, np.nan)
    return Fit(params, sd, label(lines, params))


def _standard_deviations(result, count: int) -> np.ndarray:
    """Standard deviations (count,) from the fit's Jacobian and residual spread (a flat direction: huge)."""
    jac = result.jac
    dof = max(len(result.fun) - count, 1)
    variance = float(np.sum(result.fun**2)) / dof
    information = jac.T @ jac + 1e-12 * np.eye(count)
    return np.sqrt(np.clip(np.diag(np.linalg.inv(information)), 0.0, None) * variance)
