"""Recognise which contract an ONNX pose model follows from its inputs and outputs, and build its runner.

Contracts (``--detector-format``), with their input -> outputs signatures:

- ``movenet``: int32 ``[1, H, W, 3]`` -> ``[1, 6, 56]`` (MoveNet MultiPose, bundled default).
- ``yolo-pose``: float ``[1, 3, H, W]`` -> ``[1, 5 + 3K, N]`` (ultralytics YOLO-pose export, no NMS inside).
- ``rtmo``: float ``[1, 3, H, W]`` -> dets ``[1, N, 5]`` and keypoints ``[1, N, K, 3]`` (RTMO one-stage).
- ``rtmpose``: float ``[1, 3, H, W]`` -> simcc_x ``[1, K, Wx]`` and simcc_y ``[1, K, Wy]`` (top-down, needs a
  person detector).
- ``heatmap``: float ``[1, 3, H, W]`` -> ``[1, K, H/4, W/4]`` (ViTPose / HRNet top-down, needs a person detector).

K = 17 (COCO), 26 (Halpe) or 133 (COCO-WholeBody; its 17 body points are used).
"""

from __future__ import annotations

import hashlib
from pathlib import Path

from platypose.detectors.models.detector import Detector
from platypose.detectors.models.movenet import DEFAULT_LONGEST, MoveNetMultiPose
from platypose.detectors.models.person_detector import load_person_detector
from platypose.detectors.models.rtmo import RTMO
from platypose.detectors.models.session import CPU, open_session
from platypose.detectors.models.topdown import TopDown
from platypose.detectors.models.yolo_pose import YoloPose
from platypose.lifting.errors import InputError

BUNDLED_MODEL = Path(__file__).resolve().parent / "movenet-multipose.onnx"
FORMATS: tuple[str, ...] = ("movenet", "yolo-pose", "rtmo", "rtmpose", "heatmap")
TOP_DOWN: tuple[str, ...] = ("rtmpose", "heatmap")


def _shape(node) -> tuple:
    """Static dims as ints, dynamic ones as None."""
    return tuple(d if isinstance(d, int) else None for d in node.shape)


def signature(session) -> str:
    """A one-line description of a session's inputs and outputs, for error messages."""

    def describe(nodes) -> str:
        return ", ".join(f"{n.name}{list(_shape(n))}" for n in nodes)

    return f"inputs {describe(session.get_inputs())} -> outputs {describe(session.get_outputs())}"


def recognise(session) -> str:
    """The contract (one of FORMATS) a session's signature matches; ValueError if none."""
    inputs = [_shape(n) for n in session.get_inputs()]
    outputs = [_shape(n) for n in session.get_outputs()]
    if len(inputs) != 1 or len(inputs[0]) != 4:
        raise ValueError("expected one image input of rank 4")
    image = inputs[0]
    if image[3] == 3 and len(outputs) == 1 and len(outputs[0]) == 3 and outputs[0][2] == 56:
        return "movenet"
    if image[1] != 3:
        raise ValueError("expected an NCHW image input with 3 channels (or MoveNet's NHWC)")
    ranks = sorted(len(o) for o in outputs)
    if len(outputs) == 1 and ranks == [3] and outputs[0][1] is not None and (outputs[0][1] - 5) % 3 == 0:
        return "yolo-pose"
    if (
        ranks == [3, 4]
        and any(len(o) == 3 and o[2] == 5 for o in outputs)
        and any(len(o) == 4 and o[3] == 3 for o in outputs)
    ):
        return "rtmo"
    if ranks == [3, 3] and outputs[0][1] == outputs[1][1]:
        return "rtmpose"
    if ranks == [4] and outputs[0][2] is not None and outputs[0][3] is not None:
        return "heatmap"
    raise ValueError("the outputs match no known contract")


def load_detector(
    model: str | Path | None = None,
    format: str | None = None,
    person_detector: str | Path | None = None,
    threads: int | None = None,
    provider: str = CPU,
    movenet_size: int = DEFAULT_LONGEST,
) -> Detector:
    """A ready detector for ``model`` (default: the bundled MoveNet MultiPose), its contract recognised or given.

    InputError when the model matches no contract (with its signature), the
    format is unknown, or a top-down model comes without a person detector.
    """
    path = Path(model) if model is not None else BUNDLED_MODEL
    if movenet_size < 32:
        raise InputError(f"movenet size must be at least 32 pixels, got {movenet_size}", option="movenet size")
    if format is not None and format not in FORMATS:
        raise InputError(
            f"{path}: unknown detector format {format!r}; known: {', '.join(FORMATS)}", option="detector format"
        )
    session = open_session(path, threads, provider)
    if format is None:
        try:
            format = recognise(session)
        except ValueError as err:
            raise InputError(
                f"{path}: not a known pose-model contract ({err}; {signature(session)}); see docs/keypoints.md"
            ) from None
    if format in TOP_DOWN and person_detector is None:
        raise InputError(
            f"{path}: a top-down {format} model needs person detector MODEL.onnx", option="person detector"
        )
    if format not in TOP_DOWN and person_detector is not None:
        raise InputError(
            f"{path}: person detector is only used with top-down models (rtmpose, heatmap)", option="person detector"
        )
    try:
        if format == "movenet":
            runner = MoveNetMultiPose(session, longest=movenet_size)
        elif format == "yolo-pose":
            runner = YoloPose(session)
        elif format == "rtmo":
            runner = RTMO(session)
        else:
            runner = TopDown(session, format, load_person_detector(person_detector, threads, provider))
    except ValueError as err:
        raise InputError(f"{path}: does not fit the {format} contract ({err}; {signature(session)})") from None
    models = [path] + ([Path(person_detector)] if person_detector is not None else [])
    runner.name = f"{runner.name} [{' + '.join(model_id(m) for m in models)}]"
    return runner


def model_id(path: Path) -> str:
    """``name#digest``: the file name and the start of its SHA-256, so caches tell models apart."""
    digest = hashlib.sha256()
    with open(path, "rb") as stream:
        for block in iter(lambda: stream.read(1 << 20), b""):
            digest.update(block)
    return f"{path.name}#{digest.hexdigest()[:12]}"
