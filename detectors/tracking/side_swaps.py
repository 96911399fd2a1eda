"""Left/right label swaps of a 2D detector, found by continuity over time and undone, per track.

A detector sometimes labels a person's left side as their right for a frame or a few: the whole body (it took the
person as facing the other way: every left joint jumps to where the right one was), or one pair of limb ends (two
ankles, or two wrists, near each other). Lifted as they are, such frames pull a hypothesis's limbs across its body
and turn it to face the other way for a few frames (issue 47). Undone here, before lifting, they do not.

Per track and per group of joints (the whole body first, then each pair of knees, ankles, elbows and wrists), each
frame is read either as labelled or with the group's left and right exchanged. A Viterbi pass over the track picks
the reading per frame that minimises

    sum over consecutive seen frames of  sum over the group's joints  c |x_t - x_s|^2 / size^2   +   SWAP_COST per exchanged frame,

``x_t``, ``x_s`` a joint in the two frames' readings, ``c`` the lower of its two confidences, ``size`` the person's
size (:func:`platypose.detectors.tracking.pose_metrics.person_size`). The detector's labels are kept unless exchanging them
makes the motion steadier by more than ``SWAP_COST`` a frame: where two limbs cross (a walker's ankles passing) both
readings move alike and the labels stay; a track read swapped throughout would pay on every frame, so the labels
the detector gives most of the time win.
"""

from __future__ import annotations

import numpy as np

from platypose.detectors.tracking.pose_metrics import person_size
from platypose.lifting.skeleton import JOINT_INDEX, MIRROR

SWAP_COST = 0.05  # per exchanged frame, in squared person sizes (one joint 0.22 sizes steadier pays for it)
LIMB_PAIRS = ("knee", "ankle", "elbow", "wrist")  # the pairs also exchanged alone, after the whole body
_SIDES = ("hip", "knee", "ankle", "shoulder", "elbow", "wrist")
BODY = tuple(JOINT_INDEX[f"{side}_{part}"] for part in _SIDES for side in ("left", "right"))


def exchanged(pose: np.ndarray, joints: tuple[int, ...]) -> np.ndarray:
    """Poses ``(..., 17, C)`` with each of ``joints`` given its mirror joint's values (left and right exchanged)."""
    out = pose.copy()
    out[..., list(joints), :] = pose[..., [MIRROR[j] for j in joints], :]
    return out


def swap_frames(track: np.ndarray, joints: tuple[int, ...], size: np.ndarray) -> np.ndarray:
    """Frames ``(T,)`` bool of one person's keypoints ``track`` ``(T, 17, 3)`` (confidence 0 or NaN: unseen) best read
    with ``joints`` exchanged (the module's Viterbi pass); ``size`` ``(T,)`` is the person's size per frame."""
    readings = np.stack([track[:, joints], exchanged(track, joints)[:, joints]])  # (2, T, J, 3)
    confidence = np.nan_to_num(readings[..., 2])
    seen = np.nonzero(np.isfinite(size) & (confidence[0] > 0).any(axis=-1))[0]
    if len(seen) < 2:
        return np.zeros(len(track), dtype=bool)
    here, before = readings[:, seen[1:]], readings[:, seen[:-1]]  # (2, S-1, J, 3)
    scale = np.fmax(size[seen[1:]], size[seen[:-1]])[:, None]
    weight = np.minimum(np.nan_to_num(here[None, ..., 2]), np.nan_to_num(before[:, None, ..., 2]))  # (2, 2, S-1, J)
    step = np.nan_to_num(here[None, ..., :2] - before[:, None, ..., :2])  # (from, to, S-1, J, 2)
    moves = (weight * (step**2).sum(axis=-1) / scale**2).sum(axis=-1)  # (from, to, S-1)
    total = np.array([0.0, SWAP_COST])  # best cost ending in each reading at the first seen frame
    came_from = np.zeros((len(seen) - 1, 2), dtype=np.intp)
    for k in range(len(seen) - 1):
        options = total[:, None] + moves[:, :, k]  # (from, to)
        came_from[k] = options.argmin(axis=0)
        total = options.min(axis=0) + np.array([0.0, SWAP_COST])
    reading = np.zeros(len(seen), dtype=np.intp)
    reading[-1] = total.argmin()
    for k in range(len(seen) - 2, -1, -1):
        reading[k] = came_from[k, reading[k + 1]]
    out = np.zeros(len(track), dtype=bool)
    out[seen] = reading == 1
    return out


def repair_side_swaps(keypoints: np.ndarray) -> tuple[np.ndarray, int]:
    """Tracks ``(T, P, 17, 3)`` in our joints -> (tracks with the detector's left/right swaps undone, the number of
    person-frames changed). See the module."""
    repaired = np.array(keypoints, copy=True)
    changed = np.zeros(repaired.shape[:2], dtype=bool)
    groups = [BODY] + [(JOINT_INDEX[f"left_{part}"], JOINT_INDEX[f"right_{part}"]) for part in LIMB_PAIRS]
    for p in range(repaired.shape[1]):
        for joints in groups:
            track = repaired[:, p]
            swap = swap_frames(track, joints, person_size(track))
            repaired[swap, p] = exchanged(track[swap], joints)
            changed[swap, p] = True
    return repaired, int(changed.sum())
