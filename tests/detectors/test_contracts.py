"""Model contracts on small built ONNX models with known outputs: recognition, pre/post-processing maths, errors.

The image is a real Pose2Sim frame, 1080 wide and 1920 high: letterboxed into 640 x 640 it is scaled by
1/3 (360 x 640), at x offset 140 when centred (YOLO) and 0 at the top-left (RTMO, person detectors).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from onnx_models import constant_model

from platypose.detectors.models.contracts import load_detector
from platypose.detectors.models.person_detector import decode_yolox
from platypose.detectors.models.session import ProviderFallbackWarning, open_session
from platypose.detectors.sources.video import iter_frames
from platypose.lifting.errors import InputError


@pytest.fixture(scope="module")
def frame(data_dir: Path) -> np.ndarray:
    _, image = next(iter_frames(data_dir / "video/pose2sim-balancing/cam01.mp4", max_frames=1))
    assert image.shape == (1920, 1080, 3)
    return image


def _yolo_pose_output() -> np.ndarray:
    candidates = np.zeros((4, 56), np.float32)
    candidates[:, 5:] = np.tile([240, 320, 0.8], 17)
    candidates[0, :5] = [240, 320, 100, 400, 0.9]
    candidates[0, 5:8] = [150, 100, 0.7]
    candidates[1, :5] = [245, 322, 100, 400, 0.6]  # overlaps candidate 0: suppressed
    candidates[2, :5] = [500, 300, 50, 200, 0.5]
    candidates[2, 5:] = np.tile([500, 300, 0.6], 17)
    candidates[3, :5] = [400, 400, 50, 50, 0.1]  # below the score threshold
    return candidates.T[None]


def test_yolo_pose(tmp_path: Path, frame: np.ndarray) -> None:
    model = constant_model(tmp_path / "yolo.onnx", [1, 3, 640, 640], {"output0": _yolo_pose_output()}, "images")
    detector = load_detector(model)
    assert detector.layout == "coco17" and detector.name.startswith("yolo-pose") and "yolo.onnx#" in detector.name
    other = constant_model(tmp_path / "yolo.onnx", [1, 3, 640, 640], {"output0": 0 * _yolo_pose_output()}, "images")
    nobody = load_detector(other)
    assert nobody.name != detector.name  # same file name, other weights: caches tell them apart
    assert nobody(frame).shape == (0, 17, 3)  # every score 0: nobody, with the layout's shape
    people = detector(frame)
    assert people.shape == (2, 17, 3)
    np.testing.assert_allclose(people[0, 0], [30, 300, 0.7], rtol=1e-5)
    np.testing.assert_allclose(people[0, 1], [300, 960, 0.8], rtol=1e-5)
    np.testing.assert_allclose(people[1, 5], [1080, 900, 0.6], rtol=1e-5)


def test_rtmo(tmp_path: Path, frame: np.ndarray) -> None:
    dets = np.array(
        [[[100, 100, 200, 400, 0.9], [102, 101, 201, 399, 0.8], [300, 50, 350, 250, 0.5], [0, 0, 10, 10, 0.1]]],
        np.float32,
    )
    keypoints = np.zeros((1, 4, 17, 3), np.float32)
    keypoints[0, 0] = [150, 250, 0.9]
    keypoints[0, 2] = [320, 150, 0.7]
    model = constant_model(tmp_path / "rtmo.onnx", [1, 3, 640, 640], {"dets": dets, "keypoints": keypoints})
    detector = load_detector(model)
    people = detector(frame)
    assert people.shape == (2, 17, 3)
    np.testing.assert_allclose(people[0], np.tile([450, 750, 0.9], (17, 1)), rtol=1e-5)
    np.testing.assert_allclose(people[1], np.tile([960, 450, 0.7], (17, 1)), rtol=1e-5)


def _dets_person_detector(tmp_path: Path) -> Path:
    """mmdeploy-style person detector: a person box (300, 600)-(700, 1500) in the image, and a non-person."""
    dets = np.array([[[100, 200, 700 / 3, 500, 0.9], [0, 0, 50, 50, 0.95]]], np.float32)
    labels = np.array([[0, 1]], np.float32)
    return constant_model(tmp_path / "persons.onnx", [1, 3, 640, 640], {"dets": dets, "labels": labels})


# The crop of that box: centre (500, 1050), 1.25 x (400, 900) = (500, 1125) widened to 192:256 -> 843.75 x 1125.
CROP_PX_PER_INPUT = 843.75 / 192


def test_rtmpose_with_person_detector(tmp_path: Path, frame: np.ndarray) -> None:
    simcc_x = np.zeros((1, 17, 384), np.float32)
    simcc_y = np.zeros((1, 17, 512), np.float32)
    simcc_x[0, :, 192] = 0.8  # x_in 96: the crop centre
    simcc_y[0, :, 256] = 0.6  # y_in 128
    simcc_x[0, 0], simcc_y[0, 0] = 0, 0
    simcc_x[0, 0, 0] = simcc_y[0, 0, 0] = 0.9  # joint 0 at the crop's top-left corner
    model = constant_model(tmp_path / "rtmpose.onnx", [1, 3, 256, 192], {"simcc_x": simcc_x, "simcc_y": simcc_y})
    with pytest.raises(InputError, match="needs person detector"):
        load_detector(model)
    detector = load_detector(model, person_detector=_dets_person_detector(tmp_path))
    people = detector(frame)
    assert people.shape == (1, 17, 3)
    np.testing.assert_allclose(people[0, 1], [500, 1050, 0.6], rtol=1e-5)
    np.testing.assert_allclose(
        people[0, 0], [500 - 96 * CROP_PX_PER_INPUT, 1050 - 128 * CROP_PX_PER_INPUT, 0.9], rtol=1e-5
    )


def test_heatmap_with_ultralytics_person_detector(tmp_path: Path, frame: np.ndarray) -> None:
    boxes = np.zeros((1, 84, 100), np.float32)  # [1, 4 + classes, anchors]
    boxes[0, :5, 0] = [(240 + 140 + 700 / 3) / 2, 350, 400 / 3, 300, 0.9]  # the same box, centred letterbox
    boxes[0, :4, 1] = [100, 100, 50, 50]
    boxes[0, 9, 1] = 0.99  # a confident non-person
    persons = constant_model(tmp_path / "yolo_det.onnx", [1, 3, 640, 640], {"output0": boxes}, "images")
    heatmaps = np.zeros((1, 17, 64, 48), np.float32)
    heatmaps[0, :, 32, 24] = 1.0
    heatmaps[0, :, 32, 25] = 0.5  # right neighbour higher than the left: quarter-pixel shift right
    heatmaps[0, :, 32, 23] = 0.2
    model = constant_model(tmp_path / "vitpose.onnx", [1, 3, 256, 192], {"heatmaps": heatmaps})
    detector = load_detector(model, person_detector=persons)
    people = detector(frame)
    x_in, y_in = 24.25 * 191 / 47, 32 * 255 / 63
    expected = [500 + (x_in - 96) * CROP_PX_PER_INPUT, 1050 + (y_in - 128) * CROP_PX_PER_INPUT, 1.0]
    assert people.shape == (1, 17, 3)
    np.testing.assert_allclose(people[0, 3], expected, rtol=1e-4)


def test_yolox_raw_decoding() -> None:
    raw = np.zeros((8 * 8 + 4 * 4 + 2 * 2, 6), np.float32)
    raw[9] = [0.5, 0.5, np.log(2), np.log(2), 0.8, 0.5]  # stride 8, row 1, column 1
    boxes, scores = decode_yolox(raw, (64, 64))
    np.testing.assert_allclose(boxes[9], [4, 4, 20, 20], rtol=1e-6)
    assert scores[9] == pytest.approx(0.4)
    with pytest.raises(ValueError, match="grid"):
        decode_yolox(raw[:50], (64, 64))


def test_models_that_match_no_contract(tmp_path: Path) -> None:
    odd = constant_model(tmp_path / "odd.onnx", [1, 3, 64, 64], {"logits": np.zeros((1, 10), np.float32)})
    with pytest.raises(InputError, match=r"odd\.onnx: not a known pose-model contract .*logits\[1, 10\]"):
        load_detector(odd)
    yolo = constant_model(tmp_path / "yolo.onnx", [1, 3, 640, 640], {"output0": _yolo_pose_output()}, "images")
    with pytest.raises(InputError, match="does not fit the movenet contract"):
        load_detector(yolo, format="movenet")
    ten = constant_model(
        tmp_path / "ten.onnx", [1, 3, 640, 640], {"dets": np.zeros((1, 2, 5)), "keypoints": np.zeros((1, 2, 10, 3))}
    )
    with pytest.raises(InputError, match="10 keypoints per person match no known layout"):
        load_detector(ten)
    with pytest.raises(InputError, match="model file not found"):
        load_detector(tmp_path / "absent.onnx")
    garbage = tmp_path / "garbage.onnx"
    garbage.write_bytes(b"not a model")
    with pytest.raises(InputError, match="onnxruntime cannot load it"):
        load_detector(garbage)


def test_session_threads_and_providers(tmp_path: Path, monkeypatch) -> None:
    import onnxruntime as ort

    model = constant_model(tmp_path / "m.onnx", [1, 3, 8, 8], {"y": np.zeros((1, 2), np.float32)})
    session = open_session(model, threads=1)
    assert session.get_session_options().intra_op_num_threads == 1
    assert session.get_providers() == ["CPUExecutionProvider"]
    with pytest.raises(InputError, match="execution provider NoSuchExecutionProvider is not installed"):
        open_session(model, provider="NoSuchExecutionProvider")

    class FallsBack(ort.InferenceSession):
        def get_providers(self):  # what onnxruntime reports when a GPU provider failed to initialise
            return ["CPUExecutionProvider"]

    monkeypatch.setattr(ort, "InferenceSession", FallsBack)
    monkeypatch.setattr(ort, "get_available_providers", lambda: ["CUDAExecutionProvider", "CPUExecutionProvider"])
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        open_session(model, provider="CUDAExecutionProvider")
    assert any(
        issubclass(w.category, ProviderFallbackWarning) and "runs on CPUExecutionProvider" in str(w.message)
        for w in caught
    )
