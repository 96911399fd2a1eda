"""Evaluation as in the paper's tables: project known 3D motion through cameras, lift it, score the hypotheses.

Windows are cut evenly from each clip (at the prior's frame rate), moved to
where the cameras look, projected (optionally with pixel noise), lifted by
the sequence sampler and by the frame-by-frame baseline (every frame sampled
on its own, as ZeDO does), and scored with :mod:`lifting.offline.metrics`.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass, replace

import numpy as np

from platypose.lifting.anatomy.limits import within_limits
from platypose.lifting.camera import Camera, project
from platypose.lifting.finish.measured import measure, steady_shift
from platypose.lifting.finish.representative import agreeing, median_flexion, median_motion
from platypose.lifting.finish.rigid import answer_arms, person_shape, rigid_paths
from platypose.lifting.floor import plane_floor
from platypose.lifting.job_log import JobLog
from platypose.lifting.offline import metrics
from platypose.lifting.prior.model import PriorBundle
from platypose.lifting.sampling.sampler import cameras_and_rays, sample
from platypose.lifting.settings import SamplerConfig, WindowSettings
from platypose.lifting.take import Take
from platypose.lifting.tracks.persons import root_paths
from platypose.lifting.tracks.take_lift import lift_and_finish

METRIC_NAMES = (
    "minMPJPE",
    "minMPSPE",
    "PA-MPJPE",
    "PA-MPSPE",
    "MPJVE",
    "root",
    "answer",
    "PA-answer",
    "ECE",
    "ECE worst",
)


@dataclass(frozen=True)
class EvalRow:
    """Mean metrics of one setting over all windows; lengths in millimetres, MPJVE in mm per frame."""

    method: str
    cameras: int
    frames: int
    samples: int
    windows: int
    values: dict
    seconds: float

    def as_dict(self) -> dict:
        """Plain dict for JSON."""
        return asdict(self)


def cut_windows(clips: Sequence[np.ndarray], frames: int, per_clip: int) -> tuple[list[np.ndarray], np.ndarray]:
    """Up to ``per_clip`` evenly spaced windows ``(frames, 17, 3)`` from each clip (clips shorter are skipped),
    and the index of the clip each window comes from ``(B,)``."""
    windows, clip_of_window = [], []
    for index, joints in enumerate(clips):
        if len(joints) < frames:
            continue
        starts = np.unique(np.linspace(0, len(joints) - frames, per_clip).round().astype(int))
        windows.extend(joints[s : s + frames] for s in starts)
        clip_of_window.extend([index] * len(starts))
    return windows, np.array(clip_of_window, dtype=int)


def look_target(cameras: Sequence[Camera]) -> np.ndarray:
    """The world point closest (least squares) to all cameras' optical axes; 5 m ahead of a single camera."""
    if len(cameras) == 1:
        cam = cameras[0]
        return cam.center + 5.0 * cam.R[2]
    A = np.zeros((3, 3))
    b = np.zeros(3)
    for cam in cameras:
        axis = cam.R[2]
        P = np.eye(3) - np.outer(axis, axis)
        A += P
        b += P @ cam.center
    return np.linalg.solve(A, b)


def place_window(window: np.ndarray, target: np.ndarray, floor_height: float | None = None) -> np.ndarray:
    """Translate a window so its mean pelvis is at ``target``; with ``floor_height`` only along the floor (x, y),
    and up by that height, so a motion recorded on the floor z = 0 stands on the floor z = ``floor_height``."""
    shift = target - window[:, 0].mean(0)
    if floor_height is not None:
        shift[2] = floor_height
    return window + shift


def floor_height(plane: tuple[float, float, float, float] | None) -> float | None:
    """The height of a level floor ``(nx, ny, nz, d)`` (None: none); ValueError for a tilted one."""
    if plane is None:
        return None
    nx, ny, nz, d = plane
    if abs(nx) > 1e-9 or abs(ny) > 1e-9 or nz <= 0:
        raise ValueError(f"floor {plane}: evaluation places motion on a level floor only (z = H)")
    return -d / nz


def score(hypotheses: np.ndarray, truth: np.ndarray) -> dict:
    """Position metrics of hypotheses ``(N, T, 17, 3)`` against the truth ``(T, 17, 3)``, mm (ECE: see :func:`score_windows`)."""
    return {
        "minMPJPE": 1000 * metrics.min_mpjpe(hypotheses, truth),
        "minMPSPE": 1000 * metrics.min_mpspe(hypotheses, truth),
        "PA-MPJPE": 1000 * metrics.pa_mpjpe(hypotheses, truth),
        "PA-MPSPE": 1000 * metrics.pa_mpspe(hypotheses, truth),
        "MPJVE": 1000 * metrics.mpjve(hypotheses, truth),
        "root": 1000 * metrics.root_error(hypotheses, truth),
    }


def score_windows(hypotheses: np.ndarray, truth: np.ndarray, clip_of_window: np.ndarray, answers: np.ndarray) -> dict:
    """Metrics of windows ``(B, N, F, 17, 3)`` against ``(B, F, 17, 3)``: position metrics averaged over windows,
    the single answers' ``(B, F, 17, 3)`` errors ("answer", "PA-answer"), ECE from calibration frequencies
    pooled over all windows (as the paper computes it), and "ECE worst", the largest ECE of one clip's windows
    pooled: opposite errors of two clips (one overconfident, one not confident enough) cancel in the first, not
    in the second."""
    per_window = [
        {
            **score(h, t),
            "answer": 1000 * metrics.answer_mpjpe(a, t),
            "PA-answer": 1000 * metrics.answer_pa_mpjpe(a, t),
        }
        for h, t, a in zip(hypotheses, truth, answers)
    ]
    values = {k: float(np.mean([s[k] for s in per_window])) for k in per_window[0]}
    frequencies = np.stack([metrics.calibration_frequencies(h, t) for h, t in zip(hypotheses, truth)])
    values["ECE"] = metrics.ece_from_frequencies(frequencies.mean(axis=0))
    values["ECE worst"] = max(
        metrics.ece_from_frequencies(frequencies[clip_of_window == clip].mean(axis=0))
        for clip in np.unique(clip_of_window)
    )
    return values


def lift_windows(
    prior: PriorBundle,
    cameras: Sequence[Camera],
    windows: np.ndarray,
    config: SamplerConfig,
    noise_px: float,
    frame_by_frame: bool,
    batch_windows: int = 8,
    rigid: bool = True,
) -> np.ndarray:
    """Hypotheses ``(B, N, F, 17, 3)`` for true windows ``(B, F, 17, 3)`` seen by ``cameras``; ``rigid``: made
    rigid as ``platypose lift`` makes its output (not the frame-by-frame baseline), not yet held within the joint
    limits (:func:`finished_windows` does that, after their answer)."""
    keypoints = window_keypoints(cameras, windows, noise_px, config.seed)
    pixels, confidence = keypoints[..., :2], keypoints[..., 2]
    B, F = windows.shape[:2]
    if frame_by_frame:
        pixels = pixels.reshape(len(cameras), B * F, 1, 17, 2)
        confidence = confidence.reshape(len(cameras), B * F, 1, 17)
    out = []
    chunk = batch_windows * (F if frame_by_frame else 1)
    for start in range(0, pixels.shape[1], chunk):
        part, weight = pixels[:, start : start + chunk], confidence[:, start : start + chunk]
        obs, rays = cameras_and_rays(list(cameras), part, weight, device=prior.device)
        out.append(sample(prior, obs, rays, config, frames=part.shape[2]).joints)
    joints = np.concatenate(out)  # (B or B*F, N, F or 1, 17, 3)
    if frame_by_frame:
        joints = joints.reshape(B, F, config.samples, 17, 3).transpose(0, 2, 1, 3, 4)
    elif rigid:
        joints = rigid_windows(joints, cameras, prior.fps, config.floor, keypoints, limits=False)
    return joints


def window_keypoints(
    cameras: Sequence[Camera], windows: np.ndarray, noise_px: float, seed: int, hidden: np.ndarray | None = None
) -> np.ndarray:
    """Keypoints ``(C, B, F, 17, 3)`` of true windows ``(B, F, 17, 3)`` seen by ``cameras``: their pixels with
    Gaussian noise of ``noise_px`` (drawn from ``seed``; the same for the same arguments) and confidence 1, NaN
    pixels and confidence 0 on the ``hidden`` frames (F,)."""
    rng = np.random.default_rng(seed + 1)
    pixels = np.stack([project(windows, c) for c in cameras])  # (C, B, F, 17, 2)
    pixels = pixels + rng.normal(0.0, noise_px, pixels.shape) if noise_px > 0 else pixels
    confidence = np.ones(pixels.shape[:-1])
    if hidden is not None:
        confidence[:, :, hidden] = 0.0
        pixels[:, :, hidden] = np.nan
    return np.concatenate([pixels, confidence[..., None]], axis=-1)


def rigid_windows(
    hypotheses: np.ndarray,
    cameras: Sequence[Camera],
    fps: float,
    floor: tuple[float, float, float, float] | None,
    keypoints: np.ndarray | None,
    limits: bool = True,
) -> np.ndarray:
    """Hypotheses ``(B, N, F, 17, 3)`` made rigid as a lift's output is (:func:`lifting.finish.rigid.rigid_paths`, each
    hypothesis on its own shape over its window, :func:`lifting.finish.rigid.person_shape`; with several views and
    the ``keypoints`` ``(C, B, F, 17, 3)`` they saw, first shifted as their answer's lasting offsets from those ask,
    :func:`lifting.finish.measured.steady_shift`), every view seeing every joint,
    none taken under ``floor`` (the sampler's plane, or None); ``limits`` as ``rigid_paths``'s."""
    ground = None if floor is None else plane_floor(*floor, "evaluation")
    centres = np.stack([cam.center for cam in cameras])
    seen = np.ones((hypotheses.shape[2], 17, len(cameras)), dtype=bool)
    out = np.empty_like(hypotheses)
    for b, window in enumerate(np.asarray(hypotheses, np.float64)):
        if keypoints is not None and len(cameras) > 1:
            answer = median_motion(window, agreeing(window))
            window = window + steady_shift(answer, measure(keypoints[:, b], cameras), fps)
        out[b] = rigid_paths(window, person_shape(window, len(cameras)), centres, seen, fps, ground, limits)
    return out


def finished_windows(
    hypotheses: np.ndarray,
    cameras: Sequence[Camera],
    fps: float,
    floor: tuple[float, float, float, float] | None,
    rigid: bool,
) -> tuple[np.ndarray, np.ndarray]:
    """The hypotheses and the motion a lift would export for windows of :func:`lift_windows`'s hypotheses ``(B, N, F,
    17, 3)``, as :func:`lifting.finish.rigid.rigid_person` finishes them: the answer ``(B, F, 17, 3)``
    (:func:`lifting.finish.representative.median_motion`, made rigid on its own shape), then the hypotheses held
    within the joint limits. Not ``rigid``: both as they are."""
    members = [agreeing(np.asarray(h, np.float64)) for h in hypotheses]
    answers = np.stack([median_motion(np.asarray(h, np.float64), m) for h, m in zip(hypotheses, members)])
    if not rigid:
        return hypotheses, answers
    answers = rigid_windows(answers[:, None], cameras, fps, floor, None)[:, 0]
    hypotheses = within_limits(np.asarray(hypotheses, np.float64))
    flexion = [median_flexion(h, m) for h, m in zip(hypotheses, members)]
    return hypotheses, np.stack([answer_arms(a, f, fps, len(cameras)) for a, f in zip(answers, flexion)])


def evaluate(
    prior: PriorBundle,
    clips: Sequence[np.ndarray],
    cameras: Sequence[Camera],
    frames_list: Sequence[int],
    samples_list: Sequence[int],
    config: SamplerConfig,
    windows_per_clip: int = 2,
    noise_px: float = 0.0,
    baseline: bool = True,
    progress: Callable[[str], None] | None = None,
    rigid: bool = True,
    gap_s: float = 0.0,
) -> list[EvalRow]:
    """The evaluation table: one row per method x frames x samples for these cameras.

    With ``config.floor`` set (a level floor), every window stands on it (the clips' floor is z = 0) and is
    moved only along it. ``rigid``: hypotheses made rigid as the lift's output is (:mod:`lifting.finish.rigid`).
    ``gap_s`` > 0: each window is also lifted as ``lift`` lifts a take, once seen throughout and once with a centred
    gap of that many seconds no camera sees, scored apart on the frames inside the gap and on those outside it
    (:func:`gap_rows`; always finished as a take is, whatever ``rigid``).
    """
    target = look_target(cameras)
    height = floor_height(config.floor)
    rows = []
    for frames in frames_list:
        windows, clip_of_window = cut_windows(clips, frames, windows_per_clip)
        if not windows:
            continue
        truth = np.stack([place_window(w, target, height) for w in windows])
        for samples in samples_list:
            methods = [("platypose", False)] + ([("frame-by-frame", True)] if baseline and frames > 1 else [])
            for method, per_frame in methods:
                began = time.time()
                hyps = lift_windows(
                    prior, cameras, truth, replace(config, samples=samples), noise_px, per_frame, rigid=rigid
                )
                hyps, answers = finished_windows(hyps, cameras, prior.fps, config.floor, rigid and not per_frame)
                values = score_windows(hyps, truth, clip_of_window, answers)
                row = EvalRow(method, len(cameras), frames, samples, len(windows), values, time.time() - began)
                rows.append(row)
                if progress:
                    progress(format_row(row))
            if gap_s > 0 and frames > 2:
                for row in gap_rows(
                    prior, cameras, truth, clip_of_window, replace(config, samples=samples), noise_px, gap_s
                ):
                    rows.append(row)
                    if progress:
                        progress(format_row(row))
    return rows


def centred_gap(frames: int, gap_s: float, fps: float) -> np.ndarray:
    """Frames ``(frames,)`` of a window hidden by a centred gap of ``gap_s`` seconds at ``fps`` (at least one
    frame seen on either side)."""
    length = min(max(int(round(gap_s * fps)), 1), frames - 2)
    hidden = np.zeros(frames, dtype=bool)
    first = (frames - length) // 2
    hidden[first : first + length] = True
    return hidden


def lift_as_take(
    prior: PriorBundle,
    cameras: Sequence[Camera],
    truth: np.ndarray,
    config: SamplerConfig,
    noise_px: float,
    hidden: np.ndarray | None = None,
) -> tuple[np.ndarray, np.ndarray]:
    """True windows ``(B, F, 17, 3)`` seen by ``cameras`` (none on the ``hidden`` frames ``(F,)``) lifted as a take of
    B persons on the prior's clock is: their root paths decided as ``lift`` decides them
    (:func:`platypose.lifting.tracks.persons.root_paths`), sampled through the take's windows and their anchors,
    placement across gaps included, and finished on ``config.floor`` (steady depth, bodies): the one path ``lift``
    runs (:func:`platypose.lifting.tracks.take_lift.lift_and_finish`). The hypotheses
    ``(B, N, F, 17, 3)`` and the motion the take exports, its median ``(B, F, 17, 3)``."""
    B, F = truth.shape[:2]
    keypoints = np.moveaxis(window_keypoints(cameras, truth, noise_px, config.seed, hidden), 1, 2)  # (C, F, B, 17, 3)
    times = np.arange(F) / prior.fps
    take = Take.on_clock(
        keypoints,
        times,
        np.arange(B),
        cameras,
        root_paths(keypoints, times, cameras),
        sampler=config,
        windows=WindowSettings(),
    )
    floor = None if config.floor is None else plane_floor(*config.floor, "evaluation")
    lifted = lift_and_finish(prior, take, floor=floor, log=JobLog())
    return np.asarray(lifted.hypotheses), np.asarray(lifted.median)


def gap_rows(
    prior: PriorBundle,
    cameras: Sequence[Camera],
    truth: np.ndarray,
    clip_of_window: np.ndarray,
    config: SamplerConfig,
    noise_px: float,
    gap_s: float,
) -> list[EvalRow]:
    """Windows ``truth`` ``(B, F, 17, 3)`` lifted as a take is (:func:`lift_as_take`), once seen throughout ("take")
    and once with a centred gap (:func:`centred_gap`) no camera sees; three rows: the take's metrics, and those of
    the take with the gap on the frames inside the gap ("gap inside") and on those outside it ("gap outside"), each
    labelled with the seconds the gap hid (at most the window less its first and last frame)."""
    F = truth.shape[1]
    began = time.time()
    hyps, answers = lift_as_take(prior, cameras, truth, config, noise_px)
    values = score_windows(hyps, truth, clip_of_window, answers)
    rows = [EvalRow("take", len(cameras), F, config.samples, len(truth), values, time.time() - began)]
    hidden = centred_gap(F, gap_s, prior.fps)
    began = time.time()
    hyps, answers = lift_as_take(prior, cameras, truth, config, noise_px, hidden)
    seconds, used = time.time() - began, hidden.sum() / prior.fps  # used: less than asked where the window is shorter
    for name, frames in (("gap inside", hidden), ("gap outside", ~hidden)):
        values = score_windows(hyps[:, :, frames], truth[:, frames], clip_of_window, answers[:, frames])
        rows.append(EvalRow(f"{name} {used:g}s", len(cameras), F, config.samples, len(truth), values, seconds))
    return rows


def format_header() -> str:
    """Column titles of the table."""
    cols = "".join(f"{n:>10s}" for n in METRIC_NAMES)
    return f"{'method':16s}{'cams':>5s}{'frames':>7s}{'N':>5s}{'win':>5s}{cols}{'sec':>8s}"


def format_row(row: EvalRow) -> str:
    """One table line (mm; ECE unitless)."""
    cols = "".join(f"{row.values[n]:10.3f}" if n.startswith("ECE") else f"{row.values[n]:10.1f}" for n in METRIC_NAMES)
    return f"{row.method:16s}{row.cameras:5d}{row.frames:7d}{row.samples:5d}{row.windows:5d}{cols}{row.seconds:8.1f}"
