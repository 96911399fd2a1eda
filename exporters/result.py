"""``LiftResult``: everything one input's lift produced, exactly the fields of the npz (DESIGN.md, Outputs).

A person absent from a frame has NaN in every joint of every hypothesis and of
the median at that frame; present frames are finite. Missing 2D keypoints
have confidence 0 (their coordinates may be NaN).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field
from typing import ClassVar

import numpy as np

from lifting.camera import Camera
from lifting.skeleton import JOINT_NAMES, NUM_JOINTS, PARENTS


@dataclass(frozen=True)
class LiftResult:
    """Hypotheses and their context for P persons, N hypotheses, T frames, C cameras.

    Shapes: ``hypotheses`` (P, N, T, 17, 3) float32 world metres Z up, ``median``
    (P, T, 17, 3), ``keypoints2d`` (C, P, T, 17, 3) pixels x, y and confidence,
    ``frame_times`` (T,) seconds, ``track_ids`` (P,), ``energy`` (P, N, T) or None.
    """

    hypotheses: np.ndarray
    median: np.ndarray
    keypoints2d: np.ndarray
    frame_times: np.ndarray
    fps: float
    track_ids: np.ndarray
    cameras: tuple[Camera, ...]
    energy: np.ndarray | None = None
    meta: dict = field(default_factory=dict)

    joint_names: ClassVar[tuple[str, ...]] = JOINT_NAMES
    parents: ClassVar[tuple[int, ...]] = PARENTS
    units: ClassVar[str] = "m"
    up_axis: ClassVar[str] = "z"

    def __post_init__(self) -> None:
        set_ = object.__setattr__
        set_(self, "hypotheses", np.asarray(self.hypotheses, dtype=np.float32))
        set_(self, "median", np.asarray(self.median, dtype=np.float32))
        set_(self, "keypoints2d", np.asarray(self.keypoints2d, dtype=np.float32))
        set_(self, "frame_times", np.asarray(self.frame_times, dtype=np.float64))
        set_(self, "track_ids", np.asarray(self.track_ids, dtype=np.int64))
        set_(self, "fps", float(self.fps))
        set_(self, "cameras", tuple(self.cameras))
        set_(self, "meta", dict(self.meta))
        if self.energy is not None:
            set_(self, "energy", np.asarray(self.energy, dtype=np.float32))
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
        """Frames where each person is present, (P, T) bool."""
        return np.isfinite(self.median).all(axis=(-1, -2))

    def with_meta(self, **updates: object) -> LiftResult:
        """A copy with ``meta`` updated by ``updates``."""
        return dataclasses.replace(self, meta={**self.meta, **updates})


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
    present = np.isfinite(r.median).all(axis=(-1, -2))
    if (np.isfinite(r.median).any(axis=(-1, -2)) & ~present).any():
        return "median has frames that are partly NaN (a person is either present with all joints or absent)"
    hyp_present = np.isfinite(h).all(axis=(1, -1, -2))
    hyp_absent = (~np.isfinite(h)).all(axis=(1, -1, -2))
    if not (hyp_present == present).all() or not (hyp_present | hyp_absent).all():
        return "hypotheses must be finite exactly on the frames where the median is finite"
    if np.isinf(r.keypoints2d).any():
        return "keypoints2d has infinite values"
    return ""
