"""Roll, pitch and focal length of a static camera from the straight lines of its scene, with their uncertainties
and sources, or why not.

Steps (:func:`scene_camera`): the frames' median image (people walking through vanish from it; boxes of people
who stay are masked, as are the frame's black border rows and columns), its line segments
(:mod:`platypose.lifting.calibration.scene.segments`), undistorted by the lens distortion under which the scene
explains most of them (:mod:`platypose.lifting.calibration.scene.distortion`), the vertical vanishing point
(:mod:`platypose.lifting.calibration.scene.vertical`), two orthogonal horizontal vanishing points searched along
the horizon with the focal length (:mod:`platypose.lifting.calibration.scene.manhattan`), all three fitted
together. Then twice again, each time without the segments the horizontal points explain among the vertical's
candidates (long floor edges running away from the camera look upright in the image). The vertical point gives the
roll whatever the focal length, and the pitch with it; the two horizontal points give the focal length where both
are finite and well supported. Where they are not, the pitch is the vertical point's at the given focal length (a
lens prior or the video's metadata, its spread widening the pitch's) and the focal length is "not measured". Either
way the estimate says how the pitch moves with the focal length (``pitch_slope``), so a focal length fused from
several sources (:mod:`platypose.lifting.calibration.scene.view_camera`) gets the pitch that goes with it. Frames
whose lines are not the median's mean a moving camera (:mod:`platypose.lifting.calibration.scene.motion`): no
estimate.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from platypose.lifting.calibration.lens import PRIOR, prior_focal
from platypose.lifting.calibration.scene import distortion, manhattan, motion, spread, vertical
from platypose.lifting.calibration.scene.lines import Lines, image_scale, to_lines
from platypose.lifting.calibration.scene.segments import (
    content_mask,
    lengths,
    line_detector,
    people_mask,
    unmasked_pieces,
)

MIN_LENGTH = 0.015  # segments shorter than this share of the image diagonal are left out
ROUNDS = 3
FOCAL_RANGE = (1 / 3, 3.0)  # the focal length searched, times the given one
FOCAL_MEASURED_SD = 0.10  # the lines measure the focal length when its relative sd is under this
FOCAL_PRIOR_SD = 0.3  # relative spread of a focal length the lines did not measure
FOCAL_HELD_SD = 0.05  # relative spread of a trusted one (the video's metadata: zoom, stabilisation's crop)
SLOPE_STEP = 0.05  # log focal either side of the pitch's focal length where the pitch's slope is taken
MIN_SD_DEG, MIN_FOCAL_SD = 0.3, 0.02  # floors: the principal point, lens distortion, not quite square scenes
MOTION_FRAMES = 6
RIVALS = 4  # the best solutions the bootstrap chooses among
GRID_CANDIDATES = 2  # vertical points tried for each distortion of the search (the final camera tries them all)
SAME_SOLUTION = (np.radians(0.5), np.radians(0.5), 0.03)  # solutions closer in pitch, roll, log focal are one
VERTICAL_SOURCE = "scene lines (vertical vanishing point)"
FOCAL_SOURCE = "scene lines (two orthogonal horizontal vanishing points)"
NO_DETECTOR = "no line detector (this OpenCV has no createLineSegmentDetector)"
NO_LINES = "no lines: too few upright edges meet at one vertical vanishing point"
NOT_MEASURED = "focal length not measured"


@dataclass(frozen=True)
class SceneCamera:
    """What the scene's lines say of the camera. ``problem`` set: nothing (why: no line detector, no lines,
    camera moves). Else roll and pitch (degrees), and the focal length (px) or None with ``focal_note`` saying
    why it was not measured; ``sd`` holds each quantity's standard deviation and ``source`` where it came from.
    The pitch is at the focal length ``focal_at`` (px: the lines' own, or the one given); ``pitch_slope``: degrees
    of pitch per unit of log focal length about it (the vertical vanishing point's). ``distortion``: the lens's
    radial distortion, the division model's ``k`` (:mod:`platypose.lifting.calibration.scene.distortion`; 0: none
    seen), under which every other quantity was measured."""

    roll_deg: float | None = None
    pitch_deg: float | None = None
    focal_px: float | None = None
    sd: dict[str, float] = field(default_factory=dict)
    source: dict[str, str] = field(default_factory=dict)
    segments: int = 0
    problem: str | None = None
    focal_note: str | None = None
    focal_at: float | None = None
    pitch_slope: float = 0.0
    distortion: float = 0.0


def scene_camera(
    frames: list[np.ndarray],
    boxes: list[np.ndarray] | None = None,
    focal_px: float | None = None,
    focal_source: str = PRIOR,
    focal_sd: float = FOCAL_PRIOR_SD,
) -> SceneCamera:
    """The camera of grey ``frames`` (each (H, W) uint8, spread over one take) whose people stand in ``boxes``
    (per frame (K, 4) px ``x0, y0, x1, y1``; optional). ``focal_px`` (from ``focal_source``; default the lens
    prior) is the pitch's focal length where the lines do not measure one, and the centre of the search;
    ``focal_sd``: its relative spread (the lens prior's ``FOCAL_PRIOR_SD``, the video's metadata's
    ``FOCAL_HELD_SD``), which widens the pitch's where the lines do not measure the focal length."""
    detect = line_detector()
    if detect is None:
        return SceneCamera(problem=NO_DETECTOR)
    size = frames[0].shape[:2]
    diagonal = float(np.hypot(*size))
    focal_px = prior_focal(size) if focal_px is None else focal_px
    median = np.median(np.stack(frames), axis=0).astype(np.uint8) if len(frames) > 1 else frames[0]
    allowed = content_mask(median)
    if boxes is not None:
        allowed &= ~people_mask(size, boxes)
    segments = unmasked_pieces(detect(median), allowed)
    if len(frames) >= 3:
        chosen = np.linspace(0, len(frames) - 1, min(MOTION_FRAMES, len(frames))).round().astype(int)
        moving, shares = motion.moved([unmasked_pieces(detect(frames[i]), allowed) for i in chosen], segments, diagonal)
        if moving:
            found = ", ".join(f"{100 * s:.0f}" for s in shares)
            return SceneCamera(problem=f"camera moves: frames keep {found} % of their long lines in the median")
    segments = segments[lengths(segments) >= MIN_LENGTH * diagonal]
    return _solve(segments, size, focal_px, focal_source, focal_sd)


def _solve(
    segments: np.ndarray, size: tuple[int, int], focal_px: float, focal_source: str, focal_sd: float
) -> SceneCamera:
    """:func:`scene_camera` from the scene's segments (N, 4): first the lens distortion under which the scene
    explains most of them (:func:`platypose.lifting.calibration.scene.distortion.straightest`), then its camera."""
    scale = image_scale(size)
    prior = focal_px / scale
    min_length_px = MIN_LENGTH * np.hypot(*size)

    def share(k: float) -> float:  # one round from the GRID_CANDIDATES best verticals: enough to rank distortions
        lines = _undistorted_lines(segments, size, k)
        solutions = _solutions(lines, prior, min_length_px, rounds=1, candidates=GRID_CANDIDATES)
        return manhattan.explained(lines, solutions[0].params) / lines.length.sum() if solutions else 0.0

    bend = distortion.straightest(share)[0]
    lines = _undistorted_lines(segments, size, bend)
    solutions = _solutions(lines, prior, min_length_px)
    if not solutions:
        return SceneCamera(problem=NO_LINES, segments=len(segments))
    fitted = solutions[0]
    samples = spread.bootstrap(lines, [f.params for f in solutions[:RIVALS]])
    fit_sd = np.maximum(spread.spread_of(samples), fitted.sd)
    counts = [int((fitted.labels == k).sum()) for k in range(3)]
    relative_sd = float(fit_sd[3])
    inside = FOCAL_RANGE[0] * 1.05 < fitted.focal / prior < FOCAL_RANGE[1] / 1.05
    measured = min(counts[:2]) >= manhattan.MIN_SEGMENTS and relative_sd < FOCAL_MEASURED_SD and inside
    sources = {"roll_deg": VERTICAL_SOURCE, "pitch_deg": VERTICAL_SOURCE}
    if bend != 0.0:
        sources["distortion"] = distortion.SOURCE
    note = None
    if measured:
        pitch_sd = np.degrees(fit_sd[0])
        sources["focal_px"] = FOCAL_SOURCE
        slope = _pitch_slope(lines, fitted, fitted.focal)
    else:
        held = manhattan.fit(lines, fitted.labels, fitted.params, held_focal=prior)
        slope = _pitch_slope(lines, held, prior)
        pitch_sd = float(np.hypot(np.degrees(held.sd[0]), slope * focal_sd))
        sources["pitch_deg"] = f"{VERTICAL_SOURCE} at the focal length of the {focal_source}"
        note = f"{NOT_MEASURED}: {_why_not(counts, relative_sd)}"
        fitted = held
    pitch, roll = np.degrees(fitted.params[:2])
    sd = {
        "pitch_deg": max(float(pitch_sd), MIN_SD_DEG),
        "roll_deg": max(float(np.degrees(max(fitted.sd[1], fit_sd[1]))), MIN_SD_DEG),
    }
    focal = None
    if measured:
        focal = fitted.focal * scale
        sd["focal_px"] = focal * max(float(relative_sd), MIN_FOCAL_SD)
    return SceneCamera(
        roll_deg=float(roll),
        pitch_deg=float(pitch),
        focal_px=focal,
        sd=sd,
        source=sources,
        segments=int(sum(counts)),
        focal_note=note,
        focal_at=fitted.focal * scale,
        pitch_slope=slope,
        distortion=bend,
    )


def _undistorted_lines(segments: np.ndarray, size: tuple[int, int], k: float) -> Lines:
    """The segments (N, 4) px undistorted by the division model's ``k`` as :class:`Lines`, each weighed by its
    length as seen (undistorting stretches the image's edges, which must not count as more lines explained)."""
    return replace(to_lines(distortion.undistort_segments(segments, size, k), size), length=lengths(segments))


def _pitch_slope(lines: Lines, fitted: manhattan.Fit, focal: float) -> float:
    """Degrees of pitch per unit of log focal length about ``focal`` (normalised): the vertical vanishing point of
    ``fitted``'s lines at ``SLOPE_STEP`` either side."""
    pitches = [
        manhattan.fit(lines, fitted.labels, fitted.params, held_focal=focal * np.exp(s * SLOPE_STEP)).params[0]
        for s in (-1, 1)
    ]
    return float(np.degrees(pitches[1] - pitches[0]) / (2 * SLOPE_STEP))


def _solutions(
    lines: Lines, prior: float, min_length_px: float, rounds: int = ROUNDS, candidates: int = vertical.CANDIDATES
) -> list[manhattan.Fit]:
    """The distinct cameras fitted from every candidate vertical point, the one explaining the most line length
    first, from the ``candidates`` best supported vertical points. ``rounds`` rounds, each finding the candidates
    again without the lines the best so far puts on the horizontal directions (long floor edges running away from
    the camera look upright in the image)."""
    dropped = np.zeros(len(lines), bool)
    found: list[tuple[float, manhattan.Fit]] = []
    tried: list[np.ndarray] = []  # vertical points searched already: a later round's same point is not again
    for _ in range(rounds):
        kept = np.nonzero(~dropped)[0]
        for candidate in vertical.find_verticals(lines.take(kept), prior, min_length_px, candidates):
            if any(vertical.same_point(candidate.point, point, prior) for point in tried):
                continue
            tried.append(candidate.point)
            inliers = np.zeros(len(lines), bool)
            inliers[kept[candidate.inliers]] = True
            fitted = manhattan.solve(lines, candidate.point, inliers, (prior * FOCAL_RANGE[0], prior * FOCAL_RANGE[1]))
            found.append((manhattan.explained(lines, fitted.params), fitted))
        if not found:
            break
        now = np.isin(max(found, key=lambda f: f[0])[1].labels, (0, 1))
        if np.array_equal(now, dropped):
            break
        dropped = now
    distinct: list[manhattan.Fit] = []
    for _, fitted in sorted(found, key=lambda f: -f[0]):
        if all((np.abs(fitted.params - other.params)[[0, 1, 3]] > SAME_SOLUTION).any() for other in distinct):
            distinct.append(fitted)
    return distinct


def _why_not(counts: list[int], relative_sd: float) -> str:
    """Why the horizontal lines did not measure the focal length."""
    if min(counts[:2]) < manhattan.MIN_SEGMENTS:
        return f"fewer than {manhattan.MIN_SEGMENTS} lines run along one of two level directions at right angles"
    if relative_sd >= FOCAL_MEASURED_SD:
        return f"the horizontal vanishing points fix it only within {100 * min(relative_sd, 9.99):.0f} %"
    return "it came out at the end of the range searched"
