"""The one result type every 2D keypoint source produces: tracked people on our 17 joints."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from platypose.lifting.skeleton import NUM_JOINTS


@dataclass(frozen=True)
class PoseTrack2D:
    """2D keypoints of tracked people over time, on our 17 joints (:mod:`lifting.skeleton`).

    ``keypoints`` (T, P, 17, 3) holds x_px, y_px and a confidence in [0, 1]; a
    missing detection has confidence 0 and x, y = NaN. ``frame_times`` (T,) are
    seconds from the start of the video / folder, ``track_ids`` (P,) persistent
    person IDs, ``image_size`` (height, width) in pixels, ``source`` the file,
    folder or model the keypoints came from; ``notes`` are warnings about the
    input (e.g. a truncated video) that belong in the run's log and summary.
    """

    keypoints: np.ndarray
    frame_times: np.ndarray
    track_ids: np.ndarray
    image_size: tuple[int, int]
    source: str
    notes: tuple[str, ...] = ()

    def __post_init__(self) -> None:
        keypoints = np.asarray(self.keypoints, dtype=np.float32)
        times = np.asarray(self.frame_times, dtype=np.float64)
        ids = np.asarray(self.track_ids, dtype=np.int64)
        if keypoints.ndim != 4 or keypoints.shape[2:] != (NUM_JOINTS, 3):
            raise ValueError(f"keypoints must be (T, P, {NUM_JOINTS}, 3), got {keypoints.shape}")
        if times.shape != keypoints.shape[:1]:
            raise ValueError(f"frame_times must be ({keypoints.shape[0]},), got {times.shape}")
        if ids.shape != keypoints.shape[1:2]:
            raise ValueError(f"track_ids must be ({keypoints.shape[1]},), got {ids.shape}")
        object.__setattr__(self, "keypoints", keypoints)
        object.__setattr__(self, "frame_times", times)
        object.__setattr__(self, "track_ids", ids)
        object.__setattr__(self, "image_size", (int(self.image_size[0]), int(self.image_size[1])))
        object.__setattr__(self, "notes", tuple(str(n) for n in self.notes))

    @property
    def num_frames(self) -> int:
        """Number of frames T."""
        return self.keypoints.shape[0]

    @property
    def num_persons(self) -> int:
        """Number of tracked people P."""
        return self.keypoints.shape[1]

    def select(self, person_indices: list[int] | np.ndarray) -> PoseTrack2D:
        """The same tracks restricted to the given person indices (positions along P, not IDs)."""
        index = np.asarray(person_indices, dtype=np.int64)
        return PoseTrack2D(
            self.keypoints[:, index], self.frame_times, self.track_ids[index], self.image_size, self.source, self.notes
        )
