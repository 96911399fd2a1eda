"""The one motion a lift exports per person, drawn from its hypotheses (every export carries it).

Scored by its own pelvis-relative error (``platypose eval``'s "answer" columns), the best single answer is
the per-joint middle of the hypotheses' poses: the median pose, taken around each hypothesis's own pelvis
so that where a hypothesis stands (its depth, from one camera) does not smear its pose, with the pelvis at
the median position of all the hypotheses.

The middle is taken over the hypotheses a body can be, facing one way (:func:`agreeing`): from one camera a pose
and its mirror in depth fit the keypoints alike, and the per-joint median of a pose facing the camera and one
facing away, each with its knees bent forwards, is a pose with its knees bent backwards. So, per frame, the
hypotheses with a knee bent backwards past ``HYPEREXTENSION_MARGIN_DEG`` (:mod:`lifting.anatomy.hinges`) are left out,
the others split by the way their pelvis faces (the two sides of the axis their facings spread along), and the
median is taken over the side more of them take, that choice held over ``FACING_FRAMES`` frames so that the
answer does not flip between them. A frame with no such hypothesis keeps them all.
"""

from __future__ import annotations

import warnings

import numpy as np

from platypose.lifting.anatomy.hinges import HYPEREXTENSION_MARGIN_DEG, signed_flexion
from platypose.lifting.anatomy.limits import hinge_coordinates
from platypose.lifting.skeleton import JOINT_INDEX as J

FACING_FRAMES = 9  # frames the vote for a facing is summed over (centred): a side is kept for at least this long


def _facings(hypotheses: np.ndarray) -> np.ndarray:
    """Unit direction ``(N, T, 3)`` each hypothesis's pelvis faces: right to left hip crossed into pelvis to spine."""
    left = hypotheses[..., J["left_hip"], :] - hypotheses[..., J["right_hip"], :]
    up = hypotheses[..., J["spine"], :] - hypotheses[..., J["pelvis"], :]
    forward = np.cross(left, up)
    return forward / np.maximum(np.linalg.norm(forward, axis=-1, keepdims=True), 1e-9)


def _sides(facings: np.ndarray, admissible: np.ndarray) -> np.ndarray:
    """Per hypothesis and frame ``(N, T)``, which side (+1 or -1) of the frame's facing axis it faces.

    The axis is the main direction of the admissible hypotheses' facings (an axis, not a mean: facings that
    disagree by 180 degrees lie along it), turned to agree with the previous frame's so that a side stays one
    side over time.
    """
    weights = np.nan_to_num(facings) * admissible[..., None]
    scatter = np.einsum("ntj,ntk->tjk", weights, np.nan_to_num(facings))  # (T, 3, 3)
    axes = np.linalg.eigh(scatter)[1][..., -1]  # (T, 3), the largest eigenvalue's eigenvector
    for t in range(1, len(axes)):
        if axes[t] @ axes[t - 1] < 0:
            axes[t] = -axes[t]
    return np.where(np.einsum("ntk,tk->nt", np.nan_to_num(facings), axes) >= 0, 1, -1)


def agreeing(hypotheses: np.ndarray) -> np.ndarray:
    """Which hypotheses ``(N, T)`` of ``(N, T, 17, 3)`` the answer is the median of (see the module): per frame
    those with no knee bent backwards past the margin, on the facing side more of them take over
    ``FACING_FRAMES`` frames; all of a frame's where that leaves none."""
    with np.errstate(invalid="ignore"):
        knees = signed_flexion(hypotheses)[..., :2]
    admissible = (knees >= -HYPEREXTENSION_MARGIN_DEG).all(axis=-1)  # NaN (absent) is not admissible
    sides = _sides(_facings(hypotheses), admissible)
    votes = (sides * admissible).sum(axis=0).astype(np.float64)  # (T,): for +1 minus for -1
    half = FACING_FRAMES // 2
    total = np.cumsum(np.pad(votes, (half + 1, half)))
    held = total[FACING_FRAMES:] - total[:-FACING_FRAMES]  # (T,): the votes of the frames within half of each
    chosen = np.where(held != 0, np.sign(held), np.sign(votes) + (votes == 0))
    members = admissible & (sides == chosen)
    members |= ~members.any(axis=0) & admissible  # that side has none here: any admissible one
    members |= ~members.any(axis=0)  # none admissible: all
    return members


def median_motion(hypotheses: np.ndarray, members: np.ndarray | None = None) -> np.ndarray:
    """The single answer ``(T, 17, 3)`` of hypotheses ``(N, T, 17, 3)``: the median pelvis of all of them plus the
    median pelvis-relative pose of the :func:`agreeing` ones (``members`` ``(N, T)``, if already known). Where the person stands is every hypothesis's
    middle: the agreeing ones change from frame to frame, and from one camera hypotheses metres apart in depth
    would make the answer's pelvis jump between them (a man on a roof, 2.5 m of spread: 3.8 m steps).

    A frame the hypotheses lack (NaN: the person is absent) stays NaN.
    """
    members = agreeing(hypotheses) if members is None else members
    kept = np.where(members[..., None, None], hypotheses, np.nan)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)  # an absent frame's median of nothing is NaN, as it should be
        pelvis = np.nanmedian(hypotheses[..., :1, :], axis=0)
        return pelvis + np.nanmedian(kept - kept[..., :1, :], axis=0)


def median_flexion(hypotheses: np.ndarray, members: np.ndarray) -> np.ndarray:
    """Per frame, the median flexion ``(T, 4)`` degrees (:func:`lifting.anatomy.limits.hinge_coordinates`) of each hinge
    of the ``members`` ``(N, T)`` among hypotheses ``(N, T, 17, 3)``; NaN where a frame is absent.

    The answer's arms take it (:func:`lifting.finish.rigid.rigid_person`): the median of wrists that hypotheses put
    on either side of a bent elbow is a straight arm none of them has."""
    flexion, _ = hinge_coordinates(np.nan_to_num(hypotheses))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", RuntimeWarning)
        return np.nanmedian(
            np.where(members[..., None] & np.isfinite(hypotheses).all(axis=(-1, -2))[..., None], flexion, np.nan),
            axis=0,
        )
