"""Every 2D layout maps the same real points to the same joints; synthesised joints take the least confidence."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from platypose.detectors.keypoints import model_layout, to_our_joints
from platypose.lifting.joint_maps import BODY25B_NAMES, KEYPOINT_LAYOUTS
from platypose.lifting.skeleton import JOINT_INDEX, JOINT_NAMES


@pytest.fixture(scope="module")
def body25b(data_dir: Path) -> np.ndarray:
    """The real BODY_25B people (N, 25, 3) of one Pose2Sim frame."""
    path = data_dir / "video/pose2sim-balancing/openpose-body25b/cam02_json/cam02.0040.json"
    return np.array([p["pose_keypoints_2d"] for p in json.loads(path.read_text())["people"]]).reshape(-1, 25, 3)


def _rewrite(points: np.ndarray, layout: str) -> np.ndarray:
    """The same points in another layout's order; points BODY_25B lacks are absent (confidence 0)."""
    names = KEYPOINT_LAYOUTS[layout][0]
    out = np.zeros((len(points), len(names), 3))
    for i, name in enumerate(names):
        if name in BODY25B_NAMES:
            out[:, i] = points[:, BODY25B_NAMES.index(name)]
    return out


@pytest.mark.parametrize("layout", ["coco17", "coco18", "body25", "halpe26", "wholebody133"])
def test_layouts_agree_with_body25b(body25b: np.ndarray, layout: str) -> None:
    reference = to_our_joints(body25b, "body25b")
    mapped = to_our_joints(_rewrite(body25b, layout), layout)
    others = [j for j in range(17) if j != JOINT_INDEX["neck"]]  # BODY_25B alone observes the neck
    np.testing.assert_allclose(mapped[:, others], reference[:, others], equal_nan=True)


def test_synthesised_joints_take_the_least_confidence(body25b: np.ndarray) -> None:
    person = body25b[0]
    ours = to_our_joints(person, "body25b")
    c = {name: person[BODY25B_NAMES.index(name), 2] for name in BODY25B_NAMES}
    assert ours[JOINT_INDEX["pelvis"], 2] == pytest.approx(min(c["left_hip"], c["right_hip"]))
    assert ours[JOINT_INDEX["spine"], 2] == pytest.approx(
        min(c["left_hip"], c["right_hip"], c["left_shoulder"], c["right_shoulder"])
    )
    assert ours[JOINT_INDEX["head"], 2] == pytest.approx(min(c["left_ear"], c["right_ear"]))
    np.testing.assert_allclose(ours[JOINT_INDEX["spine"], :2], person[[5, 6, 11, 12], :2].mean(axis=0))
    missing = person.copy()
    missing[BODY25B_NAMES.index("left_ear")] = 0.0  # OpenPose writes an unseen point as (0, 0, 0)
    ours = to_our_joints(missing, "body25b")
    assert ours[JOINT_INDEX["head"], 2] == 0 and np.isnan(ours[JOINT_INDEX["head"], :2]).all()


def test_platypose17_is_identity_and_counts_name_layouts() -> None:
    points = np.random.default_rng(0).uniform(1, 100, (17, 3))
    points[:, 2] = 0.5
    np.testing.assert_allclose(to_our_joints(points, "platypose17"), points)
    assert KEYPOINT_LAYOUTS["platypose17"][0] == JOINT_NAMES
    assert model_layout(17) == "coco17" and model_layout(26) == "halpe26" and model_layout(133) == "wholebody133"
    with pytest.raises(ValueError, match="25 keypoints"):
        model_layout(25)
