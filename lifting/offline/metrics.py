"""Evaluation metrics over hypotheses, as in the paper's tables (docs/prior.md, Evaluation).

Shapes: ``hypotheses`` (N, T, J, 3), ``truth`` (T, J, 3), metres in, metres out.
Position errors are measured on pelvis-relative joints (Human3.6M protocol 1);
``root_error`` reports the absolute pelvis error separately.
"""

from __future__ import annotations

import numpy as np

ECE_QUANTILES = np.linspace(0.0, 1.0, 21)


def root_relative(joints: np.ndarray) -> np.ndarray:
    """Subtract the pelvis (joint 0) from every joint, ``(..., J, 3)``."""
    return joints - joints[..., :1, :]


def joint_errors(hypotheses: np.ndarray, truth: np.ndarray) -> np.ndarray:
    """Pelvis-relative Euclidean joint errors ``(N, T, J)``."""
    return np.linalg.norm(root_relative(hypotheses) - root_relative(truth)[None], axis=-1)


def min_mpjpe(hypotheses: np.ndarray, truth: np.ndarray) -> float:
    """Mean over frames of the best hypothesis' per-frame mean joint error (frames chosen independently)."""
    return float(joint_errors(hypotheses, truth).mean(-1).min(0).mean())


def best_sequence(hypotheses: np.ndarray, truth: np.ndarray) -> int:
    """Index of the hypothesis with the lowest error over the whole sequence."""
    return int(joint_errors(hypotheses, truth).mean(axis=(1, 2)).argmin())


def min_mpspe(hypotheses: np.ndarray, truth: np.ndarray) -> float:
    """Mean joint error of the best whole-sequence hypothesis."""
    return float(joint_errors(hypotheses, truth).mean(axis=(1, 2)).min())


def procrustes_align(source: np.ndarray, target: np.ndarray) -> np.ndarray:
    """Similarity transform (rotation, scale, translation) of ``source`` onto ``target``, both ``(..., P, 3)``.

    Aligns over the P points of each leading index; returns the aligned source.
    """
    mu_s = source.mean(-2, keepdims=True)
    mu_t = target.mean(-2, keepdims=True)
    s0, t0 = source - mu_s, target - mu_t
    cov = np.swapaxes(s0, -1, -2) @ t0
    u, sigma, vt = np.linalg.svd(cov)
    sign = np.sign(np.linalg.det(u @ vt))
    d = np.ones_like(sigma)
    d[..., -1] = sign
    rotation = (u * d[..., None, :]) @ vt
    scale = (sigma * d).sum(-1) / (s0**2).sum(axis=(-1, -2))
    return scale[..., None, None] * (s0 @ rotation) + mu_t


def pa_mpjpe(hypotheses: np.ndarray, truth: np.ndarray) -> float:
    """Per frame, the best hypothesis' error after a per-frame Procrustes alignment; mean over frames."""
    aligned = procrustes_align(hypotheses, np.broadcast_to(truth, hypotheses.shape))
    return float(np.linalg.norm(aligned - truth[None], axis=-1).mean(-1).min(0).mean())


def pa_mpspe(hypotheses: np.ndarray, truth: np.ndarray) -> float:
    """Best hypothesis' error after one Procrustes alignment of its whole (pelvis-relative) sequence."""
    n, t, j, _ = hypotheses.shape
    flat_h = root_relative(hypotheses).reshape(n, t * j, 3)
    flat_t = root_relative(truth).reshape(t * j, 3)
    aligned = procrustes_align(flat_h, np.broadcast_to(flat_t, flat_h.shape))
    return float(np.linalg.norm(aligned - flat_t[None], axis=-1).mean(-1).min())


def mpjve(hypotheses: np.ndarray, truth: np.ndarray) -> float:
    """Mean per-joint velocity error (per frame) of the best whole-sequence hypothesis; 0 for one frame."""
    if truth.shape[0] < 2:
        return 0.0
    best = root_relative(hypotheses[best_sequence(hypotheses, truth)])
    velocity_error = np.diff(best, axis=0) - np.diff(root_relative(truth), axis=0)
    return float(np.linalg.norm(velocity_error, axis=-1).mean())


def root_error(hypotheses: np.ndarray, truth: np.ndarray) -> float:
    """Absolute pelvis position error of the best whole-sequence hypothesis (absolute positions)."""
    best = hypotheses[best_sequence(hypotheses, truth)]
    return float(np.linalg.norm(best[:, 0] - truth[:, 0], axis=-1).mean())


def answer_mpjpe(answer: np.ndarray, truth: np.ndarray) -> float:
    """Pelvis-relative mean joint error of one motion ``(T, J, 3)``: the single answer a lift exports."""
    return float(np.linalg.norm(root_relative(answer) - root_relative(truth), axis=-1).mean())


def answer_pa_mpjpe(answer: np.ndarray, truth: np.ndarray) -> float:
    """Mean joint error of one motion ``(T, J, 3)`` after a Procrustes alignment per frame."""
    return float(np.linalg.norm(procrustes_align(answer, truth) - truth, axis=-1).mean())


def calibration_frequencies(
    hypotheses: np.ndarray, truth: np.ndarray, quantiles: np.ndarray = ECE_QUANTILES
) -> np.ndarray:
    """Per quantile and joint, the share of frames ``(Q, J - 1)`` where the truth lies within the hypotheses' q-quantile.

    Distances are to the hypotheses' per-coordinate median (pelvis-relative; the pelvis
    itself is left out, it is 0 by construction): the truth is inside quantile q when its
    distance is below the q-quantile of the hypotheses' distances (Pierzchlewicz et al.
    2022, as the paper's evaluation computes it).
    """
    rel_h = root_relative(hypotheses)[..., 1:, :]
    rel_t = root_relative(truth)[..., 1:, :]
    median = np.median(rel_h, axis=0)
    spread = np.linalg.norm(rel_h - median[None], axis=-1)  # (N, T, J)
    gap = np.linalg.norm(rel_t - median, axis=-1)  # (T, J)
    limits = np.quantile(spread, quantiles, axis=0)  # (Q, T, J)
    return (limits > gap[None]).mean(axis=1)


def ece_from_frequencies(frequencies: np.ndarray, quantiles: np.ndarray = ECE_QUANTILES) -> float:
    """ECE from frequencies ``(Q, J)`` pooled over a whole evaluation set: mean over q of ``|median over joints - q|``."""
    return float(np.abs(np.median(frequencies, axis=1) - quantiles).mean())


def ece(hypotheses: np.ndarray, truth: np.ndarray, quantiles: np.ndarray = ECE_QUANTILES) -> float:
    """Expected calibration error of one sequence's hypotheses (see :func:`calibration_frequencies`).

    Calibration is a property of a whole evaluation set: to score many windows, average
    their :func:`calibration_frequencies` and call :func:`ece_from_frequencies` once (the
    mean of per-window ECEs is biased upwards, as frames and joints of one window share
    their errors).
    """
    return ece_from_frequencies(calibration_frequencies(hypotheses, truth, quantiles), quantiles)
