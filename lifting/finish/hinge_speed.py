"""Knees and elbows that turn as a body turns them: each hinge's flexion smoothed over time, the limb's end
turned about its hinge to match (the last step of :func:`lifting.finish.rigid.rigid_paths`).

Placed frame by frame, a hinge follows its keypoints' noise: a far person's elbow, seen by two cameras, opens
and closes by 50 degrees between frames at 60 fps (3,000 degrees a second; a fast kick's knee reaches about
1,800). Each hinge's signed flexion (:func:`lifting.anatomy.limits.hinge_coordinates`), continuous in time
because the limits keep it on one side of straight, is smoothed over each run of present frames as the one-view
bones are (:func:`lifting.finish.smoothing.smooth_over_time` at ``SMOOTHNESS``: a change at 5 Hz is halved, slower
ones pass), and the lower bone turned about the hinge's axis to the smoothed flexion: the upper bone, the
twist and every bone's length stay. A straight limb's axis is the twist's, carried over from the frames around
it where the limb is bent.
"""

from __future__ import annotations

import numpy as np
import torch

from platypose.lifting.anatomy.hinges import HINGE_JOINTS, carried_axis, hinge_bones, hinge_rests
from platypose.lifting.anatomy.limits import BENT_DEG, hinge_coordinates
from platypose.lifting.finish.smoothing import smooth_frames
from platypose.lifting.rotations import unit

SMOOTHNESS = 1.0  # at 30 fps, scaled with the frame rate to the same cut-off in Hz


def _filled(values: np.ndarray, known: np.ndarray) -> np.ndarray:
    """``values`` ``(T,)`` with the frames not ``known`` interpolated from those that are (0 where none is)."""
    if not known.any():
        return np.zeros_like(values)
    frames = np.arange(len(values))
    return np.interp(frames, frames[known], values[known])


def hinge_axes(joints: np.ndarray, twist: np.ndarray, bent: np.ndarray) -> np.ndarray:
    """Per hinge, the axis ``(K, T, 4, 3)`` its positive flexion turns about, for joints ``(K, T, 17, 3)`` with
    ``twist`` degrees ``(K, T, 4)``: where a limb is not ``bent`` ``(K, T, 4)``, the twist of the frames around."""
    values = torch.as_tensor(joints)
    neutral, down = hinge_rests(values)
    upper = hinge_bones(values)[0]
    carried = carried_axis(neutral, down, upper).numpy()
    twist = np.stack(
        [[_filled(twist[k, :, h], bent[k, :, h]) for h in range(twist.shape[2])] for k in range(len(twist))]
    ).transpose(0, 2, 1)
    turn, upper = np.radians(twist)[..., None], upper.numpy()
    axes = np.cos(turn) * carried + np.sin(turn) * np.cross(upper, carried)
    return unit(axes - np.sum(axes * upper, axis=-1, keepdims=True) * upper)  # overhead, the carried axis is not


def with_flexion(joints: np.ndarray, flexion: np.ndarray, hinges: tuple[int, ...] = (0, 1, 2, 3)) -> np.ndarray:
    """Motions ``(K, T, 17, 3)`` (all present) with the lower bone of each of ``hinges`` (:data:`HINGE_JOINTS` indices)
    turned about the hinge's axis to ``flexion`` degrees ``(K, T, 4)``: the upper bone, the twist and the bones'
    lengths stay."""
    out = np.array(joints, np.float64, copy=True)
    now, twist = hinge_coordinates(out)
    axes = hinge_axes(out, twist, np.abs(now) > BENT_DEG)
    for h in hinges:
        top, mid, low = HINGE_JOINTS[h]
        upper = unit(out[:, :, mid] - out[:, :, top])
        length = np.linalg.norm(out[:, :, low] - out[:, :, mid], axis=-1, keepdims=True)
        angle = np.radians(flexion[:, :, h])[..., None]
        out[:, :, low] = out[:, :, mid] + length * (
            np.cos(angle) * upper + np.sin(angle) * np.cross(axes[:, :, h], upper)
        )
    return out


def steady_hinges(
    joints: np.ndarray,
    present: np.ndarray,
    fps: float,
    flexion: np.ndarray | None = None,
    hinges: tuple[int, ...] = (0, 1, 2, 3),
) -> np.ndarray:
    """Motions ``(K, T, 17, 3)`` with the flexion of each of ``hinges`` smoothed over the runs of ``present`` ``(T,)``
    frames (see the module), or set to ``flexion`` ``(K, T, 4)`` degrees smoothed so (a target from elsewhere);
    absent frames as they are."""
    out = np.array(joints, np.float64, copy=True)
    frames = np.flatnonzero(present)
    if len(frames) < 3:
        return out
    flexion = hinge_coordinates(out[:, frames])[0] if flexion is None else np.array(flexion[:, frames], np.float64)
    runs = np.split(np.arange(len(frames)), np.flatnonzero(np.diff(frames) > 1) + 1)
    for run in runs:
        flexion[:, run] = smooth_frames(flexion[:, run], SMOOTHNESS * (fps / 30.0) ** 4)
    out[:, frames] = with_flexion(out[:, frames], flexion, hinges)
    return out
