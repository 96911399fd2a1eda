"""Steady depth for a person seen by one camera: each hypothesis's root moves continuously along its ray.

Applied where the lift is grounded on a floor (standing feet then fix depth, the frames this trusts). One view
fixes where a person is in the image, not how far: the sampler places each window by the size prior, or by
a stance foot's ray meeting the floor. Where neither holds (a flip in the air, a crouch, a person back after a
detection gap), a hypothesis's depth jumps: the Sports2D roof man, unseen for 1.5 s, came back 6 m nearer than he
left and slid 8 m back while landing. Here each hypothesis's pelvis depth path (log of its distance along the
camera's optical axis) is smoothed over the person's whole track, gaps included:

    minimise  sum_t w_t (y_t - x_t)^2  +  mu * sum_t (y_{t+1} - y_t)^2  +  lam * sum_t (y_{t+1} - 2 y_t + y_{t-1})^2

over the track's frames from first to last present (absent frames have no data term, so the path crosses a gap
continuously from where it was, and the hypotheses keep their own paths: those whose depth the gap leaves open
spread as they did). ``w_t`` is 1 where the hypothesis's lower ankle stands on the floor (within
``STANDING_BAND`` of its standing height there, :func:`lifting.stance.standing_heights`, and that height the
floor's: :func:`on_floor`) and the frame is trusted (:func:`trusted_frames`: most joints seen, not a blip): a
stance foot's ray meeting the known floor fixes depth. Elsewhere only the size prior placed the frame, and
``w_t`` is ``UNMEASURED_WEIGHT``: in the air, and standing on a raised support, whose height is the hypothesis's
own guess and moves with its depth (the Sports2D roof man, weighed 1 there, wandered 2 m to and fro along his
rays in 4 s on the roof: 4.3 m of his pelvis path of 12.8 m). ``lam``
and ``mu`` (a prior on the root's speed and acceleration along the ray) pass changes slower than ``CUTOFF_HZ`` where
the data weigh 1, and slower than about 0.5 Hz where they weigh ``UNMEASURED_WEIGHT`` (a walk at a steady speed
along the ray passes whatever the weight: only its changes of speed are smoothed). Each frame is then scaled about
the camera centre by the ratio of the smoothed to the raw depth: every joint moves along its own ray, so the image
is unchanged. A scale never takes a joint under the floor that was not under it.
"""

from __future__ import annotations

import numpy as np
from scipy import sparse
from scipy.sparse.linalg import spsolve

from platypose.lifting.camera import Camera
from platypose.lifting.floor import Floor
from platypose.lifting.sampling.placement import SIZE_LIMITS
from platypose.lifting.stance import ANKLE_HEIGHT, ANKLES, lower_height, standing_heights
from platypose.lifting.tracks.roots import MIN_SEEN_JOINTS

CUTOFF_HZ = 3.0  # depth changes slower than this pass where the feet stand (they hold depth: barely touched)
UNMEASURED_WEIGHT = 5e-4  # data weight of frames no floor contact places (changes over about 0.5 Hz smoothed)
STANDING_BAND = 0.1  # metres: a lower ankle within this of the floor (or its own low level) stands
MIN_SEEN = 10  # joints the camera must see in a frame for its placement to count fully
MIN_RUN = 0.2  # seconds: a shorter run of such frames is a blip, placed by the prior alone
MIN_GAP = 0.2  # seconds unseen: the depth after such a gap is carried over from before it (floor_contact_depths)
SUPPORT_BEFORE = 1.0  # seconds seen before a gap over which a hypothesis's level there is taken
MIN_DROP = 0.05  # metres: a stance this far below the camera at least has a ray that meets the floor


def smooth_path(
    values: np.ndarray, weights: np.ndarray, lam: float, mu: float = 0.0, spacing: np.ndarray | None = None
) -> np.ndarray:
    """The minimiser ``y`` ``(T,)`` of ``sum w (y - x)^2 + mu * sum (first derivative of y)^2 + lam * sum (second
    derivative of y)^2`` for ``values`` ``(T,)`` (NaN: no data) and ``weights`` ``(T,)``, samples ``spacing``
    ``(T - 1,)`` frames apart (default 1: uneven spacing, as a variable-rate video's, weighs each term by the time
    it covers, so fewer samples of the same path give the same path)."""
    known = np.isfinite(values)
    T = len(values)
    if T < 3:
        return np.where(known, values, np.nanmean(values))
    h = np.ones(T - 1) if spacing is None else np.maximum(np.asarray(spacing, np.float64), 1e-6)
    covered = np.concatenate([[h[0]], h]) / 2 + np.concatenate([h, [h[-1]]]) / 2  # time each sample stands for
    w = np.where(known, weights, 0.0) * covered
    x = np.where(known, values, 0.0)
    first = sparse.diags([-1 / h, 1 / h], [0, 1], shape=(T - 1, T))
    left, right = 1 / h[:-1], 1 / h[1:]
    span = (h[:-1] + h[1:]) / 2
    second = sparse.diags([left / span, -(left + right) / span, right / span], [0, 1, 2], shape=(T - 2, T))
    system = lam * second.T @ sparse.diags(span) @ second + mu * first.T @ sparse.diags(h) @ first
    system = system + sparse.diags(w + 1e-9)
    return spsolve(system.tocsc(), w * x)


def trusted_frames(seen: np.ndarray, fps: float) -> np.ndarray:
    """Frames ``(T,)`` whose placement counts fully, from the joints seen per frame ``seen`` ``(T,)``: at least
    ``MIN_SEEN`` joints, in a run of such frames lasting ``MIN_RUN`` seconds or more (a blip of a few frames, a person
    half out of the image, is placed by the prior alone and must not drag the rest of the track)."""
    good = np.asarray(seen) >= MIN_SEEN
    edges = np.flatnonzero(np.diff(np.concatenate([[0], good.astype(np.int8), [0]])))
    trusted = np.zeros(len(good), bool)
    for start, stop in zip(edges[::2], edges[1::2]):
        trusted[start:stop] = stop - start >= MIN_RUN * fps
    return trusted


def steady_scales(
    pelvis: np.ndarray,
    lower_ankle: np.ndarray,
    camera: Camera,
    fps: float,
    *,
    trusted: np.ndarray | None = None,
    times: np.ndarray | None = None,
    unseen: np.ndarray | None = None,
    camera_height: float | None = None,
) -> np.ndarray:
    """Per hypothesis and frame, the factor ``(N, T)`` to scale the frame about the camera centre by: pelvises
    ``(N, T, 3)`` (NaN where absent), lower-ankle heights ``(N, T)``, ``trusted`` frames ``(T,)``
    (:func:`trusted_frames`; others weigh as airborne ones), frame ``times`` ``(T,)`` (default: every 1 / ``fps``);
    1 outside the track. With ``unseen`` frames ``(T,)`` (no view sees the person) and the camera centre's
    ``camera_height`` above the floor, a hypothesis standing after a gap at another level than before it takes
    its depth there from the floor contact (:func:`floor_contact_depths`)."""
    depth = (pelvis - camera.center) @ camera.R[2]  # (N, T) along the optical axis
    present = np.isfinite(depth).all(axis=0) & (np.nan_to_num(depth, nan=-1.0) > 0).all(axis=0)
    scales = np.ones(depth.shape)
    frames = np.flatnonzero(present)
    if len(frames) < 3:
        return scales
    span = slice(frames[0], frames[-1] + 1)
    response = 2 - 2 * np.cos(2 * np.pi * CUTOFF_HZ / fps)  # of a first difference at the cut-off
    lam, mu = 1.0 / response**2, 1.0 / response
    ankle = np.where(present, lower_ankle, np.nan)[:, span]
    levels = standing_heights(ankle, fps)  # (N, t)
    standing = np.abs(np.nan_to_num(ankle - levels, nan=np.inf)) < STANDING_BAND
    if trusted is not None:
        standing &= trusted[span]
    spacing = None if times is None else np.diff(np.asarray(times, np.float64)[span]) * fps
    log_depth = np.where(present, np.log(np.where(present, depth, 1.0)), np.nan)[:, span]
    targets, measured = log_depth, standing
    if camera_height is not None:
        measured = standing & on_floor(levels, camera_height)
    if unseen is not None and camera_height is not None:  # after a gap, a stance at a new level: on the floor
        contact = floor_contact_depths(log_depth, np.where(standing, levels, np.nan), unseen[span], camera_height, fps)
        targets = np.where(np.isfinite(contact), contact, log_depth)
        measured = measured | np.isfinite(contact)
    weights = np.where(measured, 1.0, UNMEASURED_WEIGHT)
    if unseen is not None:  # the depth the prior carried across a gap only bridges it
        weights = np.where(unseen[span], 0.0, weights)
    for n in range(len(depth)):
        smooth = smooth_path(targets[n], weights[n], lam, mu, spacing)
        scales[n, span] = np.where(np.isfinite(log_depth[n]), np.exp(smooth - np.nan_to_num(log_depth[n])), 1.0)
    return scales


def on_floor(levels: np.ndarray, camera_height: float) -> np.ndarray:
    """Where standing heights ``levels`` (any shape, of the lower ankle; NaN: not standing) are the floor's (an ankle
    ``ANKLE_HEIGHT`` above it, within ``STANDING_BAND``) and the camera at least ``MIN_DROP`` above the floor: a
    stance whose ray meets the known floor. A raised support's height is the hypothesis's own guess, which its
    depth moves with; a floor seen edge-on fixes nothing."""
    on = np.abs(np.nan_to_num(levels, nan=np.inf) - ANKLE_HEIGHT) < STANDING_BAND
    return on & (camera_height > MIN_DROP)


def gap_runs(unseen: np.ndarray, fps: float) -> list[tuple[int, int]]:
    """The runs ``(first, stop)`` of ``unseen`` frames ``(T,)`` lasting ``MIN_GAP`` seconds or more, in order."""
    edges = np.flatnonzero(np.diff(np.concatenate([[0], np.asarray(unseen, np.int8), [0]])))
    return [(int(a), int(b)) for a, b in zip(edges[::2], edges[1::2]) if b - a >= MIN_GAP * fps]


def floor_contact_depths(
    log_depth: np.ndarray, levels: np.ndarray, unseen: np.ndarray, camera_height: float, fps: float
) -> np.ndarray:
    """Log depths ``(N, T)`` that put a hypothesis standing after a gap on the floor, NaN elsewhere.

    ``log_depth`` ``(N, T)`` are the hypotheses' own, ``levels`` ``(N, T)`` their standing heights above the floor
    where they stand on a seen frame (NaN elsewhere), ``unseen`` ``(T,)`` the frames no view sees. Across a gap (:func:`gap_runs`) a
    hypothesis's depth is the one carried over from before it, which one view cannot check: a person who jumped
    down from a roof while unseen stood on at roof level. After a gap, up to the next, a hypothesis standing at
    another level than it stood on over the ``SUPPORT_BEFORE`` seconds seen before the gap (or with no such
    frames) is scaled about the camera centre until its stance is at ``ANKLE_HEIGHT`` on the floor, where its
    ankle's ray meets the floor (at least ``MIN_DROP`` below the camera), by at most the size prior's ``SIZE_LIMITS``. One standing at its level from before
    keeps its depth (a person back on the same roof, step or floor)."""
    contact = np.full(log_depth.shape, np.nan)
    drop = camera_height - levels
    reachable = drop > MIN_DROP
    scale = np.clip((camera_height - ANKLE_HEIGHT) / np.where(reachable, drop, 1.0), *SIZE_LIMITS)
    on_floor = log_depth + np.log(scale)
    runs = gap_runs(unseen, fps)
    for k, (first, stop) in enumerate(runs):
        end = runs[k + 1][0] if k + 1 < len(runs) else len(unseen)
        before = levels[:, max(first - round(SUPPORT_BEFORE * fps), 0) : first]
        level = np.array([np.nanmedian(row) if np.isfinite(row).any() else np.nan for row in before])  # (N,)
        moved = ~(np.abs(levels[:, stop:end] - level[:, None]) < STANDING_BAND)  # NaN level: moved
        take = reachable[:, stop:end] & moved & np.isfinite(levels[:, stop:end])
        contact[:, stop:end] = np.where(take, on_floor[:, stop:end], np.nan)
    return contact


def floor_safe(scales: np.ndarray, joints_height: np.ndarray, camera_height: float) -> np.ndarray:
    """``scales`` ``(N, T)`` capped so that no joint (heights ``(N, T, J)`` above the floor) ends under the floor
    that was not under it: a joint below the camera sinks as its frame is scaled up."""
    below = joints_height < camera_height - 1e-6
    floor_of = np.minimum(joints_height, 0.0)
    limit = np.where(below, (camera_height - floor_of) / np.maximum(camera_height - joints_height, 1e-6), np.inf)
    return np.minimum(scales, np.nan_to_num(limit.min(axis=-1), nan=np.inf))


def steady_person(
    hypotheses,
    p: int,
    camera: Camera,
    fps: float,
    floor: Floor | None,
    seen: np.ndarray,
    *,
    times: np.ndarray | None = None,
    chunk: int = 1024,
) -> float:
    """Steady the depth of person ``p`` of ``hypotheses`` ``(P, N, T, 17, 3)`` (an array or anything indexed like one)
    seen by ``camera`` (``seen`` ``(T,)``: joints it sees per frame) standing on ``floor``
    (None: heights along z), at frame ``times`` ``(T,)`` (default: every 1 / ``fps``), in place; the largest change of a pelvis
    depth made (metres)."""
    T = hypotheses.shape[2]
    pelvis = np.concatenate([np.asarray(hypotheses[p, :, s : s + chunk, 0], np.float64) for s in range(0, T, chunk)], 1)
    ankles = np.concatenate(
        [np.asarray(hypotheses[p, :, s : s + chunk][:, :, list(ANKLES)], np.float64) for s in range(0, T, chunk)], 1
    )
    height = (lambda x: floor.height(x)) if floor is not None else (lambda x: x[..., 2])
    unseen = np.asarray(seen) < MIN_SEEN_JOINTS
    camera_height = float(height(camera.center))
    lower = lower_height(height(ankles))
    scales = steady_scales(
        pelvis,
        lower,
        camera,
        fps,
        trusted=trusted_frames(seen, fps),
        times=times,
        unseen=unseen,
        camera_height=camera_height,
    )
    centre = camera.center
    moved = 0.0
    for start in range(0, T, chunk):
        block = np.asarray(hypotheses[p, :, start : start + chunk], np.float64)  # (N, t, 17, 3)
        scale = scales[:, start : start + chunk]
        if floor is not None:
            scale = floor_safe(scale, floor.height(block), float(floor.height(centre)))
        shifted = centre + scale[..., None, None] * (block - centre)
        change = np.linalg.norm(shifted[:, :, 0] - block[:, :, 0], axis=-1)
        moved = max(moved, float(np.nanmax(change, initial=0.0)))
        hypotheses[p, :, start : start + chunk] = np.where(np.isfinite(block), shifted, block).astype(np.float32)
    return moved
