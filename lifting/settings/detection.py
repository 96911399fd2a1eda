"""The settings of reading or detecting one view's 2D: the pose model, where it runs, which frames, the cache."""

from __future__ import annotations

import numbers
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path

from platypose.lifting.errors import InputError
from platypose.lifting.settings.fields import check_types, setting


@dataclass(frozen=True)
class DetectOptions:
    """How a view becomes 2D tracks: precomputed keypoints read (their ``fps`` and ``image_size`` when no video
    lies beside them) or a video detected (the model, its runtime, the frames, the cache beside the outputs).

    Every field is an option of every command taking the group (``detect``; ``lift`` all but those a lift leaves to
    its own options or defaults), and :func:`platypose.lift` takes those of a lift.
    """

    detector: Path | None = setting(
        None,
        "Pose model .onnx (default: the bundled MoveNet MultiPose).",
        short="Pose model .onnx (default: bundled MoveNet).",
        option=True,
    )
    detector_format: str | None = setting(
        None,
        "Model contract: movenet, yolo-pose, rtmo, rtmpose, heatmap (default: recognised).",
        short="Model contract (default: recognised).",
        option=True,
    )
    person_detector: Path | None = setting(
        None,
        "Person detector .onnx for top-down models (rtmpose, heatmap).",
        short="Person detector for top-down models.",
        option=True,
    )
    movenet_size: int = setting(384, "MoveNet input: longer side in pixels (multiple of 32).", option=True)
    threads: int | None = setting(None, "onnxruntime intra-op threads (default: all cores).", option=True)
    provider: str = setting("CPUExecutionProvider", "onnxruntime execution provider.", option=True)
    stride: int = setting(1, "Detect every N-th frame.", minimum=1, option=True)
    max_frames: int | None = setting(None, "Stop after this many processed frames.", minimum=1, option=True)
    fps: float | None = setting(
        None,
        "Frame rate of precomputed keypoints (default: from the video beside them).",
        short="Frame rate of keypoints without a video beside them.",
        finite=False,
        option=True,
    )
    image_size: tuple[int, int] | None = setting(
        None,
        "HEIGHTxWIDTH of precomputed keypoints (default: from the video).",
        short="HEIGHTxWIDTH of keypoints without a video.",
        option=True,
    )
    cache: bool = setting(True, "Reuse detections cached in OUT/<name>/ from an earlier run.", option=True)

    def __post_init__(self) -> None:
        fps, size, threads = self.fps, self.image_size, self.threads
        if threads is not None and not _is_count(threads):
            raise InputError(f"threads must be an integer >= 1, got {threads!r}", option="threads")
        # the upper bound (infinity included) is the keypoint reader's to check: its message names the file
        if fps is not None and not (isinstance(fps, numbers.Real) and not isinstance(fps, bool) and fps > 0):
            raise InputError(f"fps must be a positive number, got {fps!r}", option="fps")
        pair = isinstance(size, Sequence) and not isinstance(size, str) and len(size) == 2
        if size is not None and not (pair and all(_is_count(v) for v in size)):
            raise InputError(f"image_size must be (height, width) in pixels, got {size!r}", option="image_size")
        check_types(self)


def _is_count(value: object) -> bool:
    """Whether ``value`` is an integer of at least 1."""
    return isinstance(value, numbers.Integral) and not isinstance(value, bool) and value >= 1
