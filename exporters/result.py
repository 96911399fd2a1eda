"""``LiftResult``: everything one input's lift produced, exactly the fields of the npz (docs/outputs.md).

A person absent from a frame has NaN in every joint of every hypothesis and of
the median at that frame; present frames are finite. Missing 2D keypoints
have confidence 0 (their coordinates may be NaN).

``hypotheses``, ``median`` and ``energy`` may be :class:`exporters.frames.FrameArray`
files (long inputs): everything here and in the exporters reads them in chunks of frames.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from platypose.exporters.frames import FrameArray, frame_chunks
from platypose.exporters.presence import present_frames
from platypose.lifting.camera import Camera
from platypose.lifting.skeleton import JOINT_NAMES, NUM_JOINTS, PARENTS
from platypose.lifting.tracks.roots import seen_frames


@dataclass(frozen=True)
class LiftResult:
    """Hypotheses and their context for P persons, N hypotheses, T frames, C cameras.

    Shapes: ``hypotheses`` (P, N, T, 17, 3) float32 world metres Z up, ``median``
    (P, T, 17, 3), ``keypoints2d`` (C, P, T, 17, 3) pixels x, y and confidence,
    ``frame_times`` (T,) seconds, ``track_ids`` (P,), ``energy`` (P, N, T) or None.
    """

    hypotheses: np.ndarray | FrameArray
    median: np.ndarray | FrameArray
    keypoints2d: np.ndarray
    frame_times: np.ndarray
    fps: float
    track_ids: np.ndarray
    cameras: tuple[Camera, ...]
    energy: np.ndarray | FrameArray | None = None
    meta: dict = field(default_factory=dict)

    joint_names: ClassVar[tuple[str, ...]] = JOINT_NAMES
    parents: ClassVar[tuple[int, ...]] = PARENTS
    units: ClassVar[str] = "m"
    up_axis: ClassVar[str] = "z"

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "hypotheses", _float32(self.hypotheses))
        set_(self, "median", _float32(self.median))
        set_(self, "keypoints2d", np.asarray(self.keypoints2d, dtype=np.float32))
        set_(self, "frame_times", np.asarray(self.frame_times, dtype=np.float64))
        set_(self, "track_ids", np.asarray(self.track_ids, dtype=np.int64))
        set_(self, "fps", float(self.fps))
        set_(self, "cameras", tuple(self.cameras))
        set_(self, "meta", dict(self.meta))
        if self.energy is not None:
            set_(self, "energy", _float32(self.energy))
        problem = _shape_problem(self)
        if problem:
            raise ValueError(problem)

    @property
    def num_persons(self) -> int:
        """P."""
        return self.hypotheses.shape[0]

    @property
    def num_hypotheses(self) -> int:
        """N."""
        return self.hypotheses.shape[1]

    @property
    def num_frames(self) -> int:
        """T."""
        return self.hypotheses.shape[2]

    def present(self) -> np.ndarray:
        """Frames where each person is present, (P, T) bool: the median finite and a body, not collapsed to a point
        (:func:`platypose.exporters.presence.present_frames`)."""
        return np.concatenate([present_frames(self.median[:, t]) for t in frame_chunks(self.num_frames)], axis=1)

    def collapsed(self) -> list[int]:
        """Track ids of persons whose median is finite in some frame but a body in none (collapsed to a point)."""
        present = self.present().any(axis=1)
        finite = np.zeros(self.num_persons, dtype=bool)
        for t in frame_chunks(self.num_frames):
            finite |= np.isfinite(self.median[:, t]).all(axis=(-1, -2)).any(axis=1)
        return [int(track) for track, on, seen in zip(self.track_ids, present, finite) if seen and not on]

    def seen(self) -> np.ndarray:
        """Frames where some view sees each person, (P, T) bool: a present frame that is not seen was filled by
        the prior (a detection gap lifted through)."""
        return seen_frames(np.moveaxis(self.keypoints2d, 1, 2))

    def with_meta(self, **updates: object) -> LiftResult:
        """A copy with ``meta`` updated by ``updates``."""
        return dataclasses.replace(self, meta={**self.meta, **updates})


def _float32(values: np.ndarray | FrameArray) -> np.ndarray | FrameArray:
    """An array as float32; a FrameArray is kept (it must already be float32)."""
    if isinstance(values, FrameArray):
        if values.dtype != np.float32:
            raise ValueError(f"{values.path}: must hold float32, got {values.dtype}")
        return values
    return np.asarray(values, dtype=np.float32)


def _presence_problem(r: LiftResult) -> str:
    """Whether median and hypotheses are finite or NaN together, chunk by chunk of frames; empty when they are."""
    for t in frame_chunks(r.num_frames):
        median, h = r.median[:, t], r.hypotheses[:, :, t]
        present = np.isfinite(median).all(axis=(-1, -2))
        if (np.isfinite(median).any(axis=(-1, -2)) & ~present).any():
            return "median has frames that are partly NaN (a person is either present with all joints or absent)"
        hyp_present = np.isfinite(h).all(axis=(1, -1, -2))
        hyp_absent = (~np.isfinite(h)).all(axis=(1, -1, -2))
        if not (hyp_present == present).all() or not (hyp_present | hyp_absent).all():
            return "hypotheses must be finite exactly on the frames where the median is finite"
    return ""


def _shape_problem(r: LiftResult) -> str:
    """The first inconsistency among the fields of ``r``, or an empty string."""
    h = r.hypotheses
    if h.ndim != 5 or h.shape[3:] != (NUM_JOINTS, 3):
        return f"hypotheses must be (P, N, T, {NUM_JOINTS}, 3), got {h.shape}"
    P, N, T = h.shape[:3]
    if N < 1 or T < 1:
        return f"hypotheses need at least one hypothesis and one frame, got {h.shape}"
    C = len(r.cameras)
    if C < 1:
        return "a result needs at least one camera (the one its 2D keypoints come from)"
    expected = {
        "median": (r.median.shape, (P, T, NUM_JOINTS, 3)),
        "keypoints2d": (r.keypoints2d.shape, (C, P, T, NUM_JOINTS, 3)),
        "frame_times": (r.frame_times.shape, (T,)),
        "track_ids": (r.track_ids.shape, (P,)),
    }
    if r.energy is not None:
        expected["energy"] = (r.energy.shape, (P, N, T))
    for name, (got, want) in expected.items():
        if got != want:
            return f"{name} must be {want} to match hypotheses {h.shape} and {C} cameras, got {got}"
    if not all(isinstance(c, Camera) for c in r.cameras):
        return "cameras must be lifting.camera.Camera objects"
    if not (np.isfinite(r.fps) and r.fps > 0):
        return f"fps must be positive, got {r.fps}"
    if not np.isfinite(r.frame_times).all() or (T > 1 and not (np.diff(r.frame_times) > 0).all()):
        return "frame_times must be finite and strictly increasing"
    if len(set(r.track_ids.tolist())) != P:
        return f"track_ids must be distinct, got {r.track_ids.tolist()}"
    if np.isinf(r.keypoints2d).any():
        return "keypoints2d has infinite values"
    return _presence_problem(r)
