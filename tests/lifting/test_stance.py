"""One definition of which ankle stands (lifting/stance.py): the floor's estimate, grounding, finishing and the
checks take the ankles, the lower ankle and the standing height from it, and no other module defines them."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np

from platypose.lifting.floor import stance_points
from platypose.lifting.stance import ANKLES, lower_ankles, stance_ankles

REPO = Path(__file__).resolve().parents[2]
STANCE_NAMES = {
    "ANKLES",
    "ANKLE_HEIGHT",
    "STANCE_SPEED",
    "STANCE_BAND",
    "MIN_STANCE",
    "SUPPORT_WINDOW",
    "STANDING_QUANTILE",
    "ankle_heights",
    "lower_height",
    "lower_ankles",
    "standing_heights",
    "stance_ankles",
    "lasting",
}


def test_only_lifting_stance_defines_which_ankle_stands():
    defined = []
    for path in sorted((REPO / "lifting").rglob("*.py")):
        if path == REPO / "lifting" / "stance.py":
            continue
        for node in ast.parse(path.read_text()).body:
            names = [node.name] if isinstance(node, ast.FunctionDef) else []
            if isinstance(node, ast.Assign):
                names = [t.id for t in node.targets if isinstance(t, ast.Name)]
            defined += [f"{path.relative_to(REPO)}: {n}" for n in names if n in STANCE_NAMES]
    assert defined == []


def test_the_lower_ankle_is_both_on_a_tie_and_never_an_unknown_one():
    heights = np.array([[0.1, 0.3], [0.2, 0.2], [np.nan, 0.4], [np.nan, np.nan]])
    assert lower_ankles(heights).tolist() == [[True, False], [True, True], [False, True], [False, False]]


def test_the_floor_and_the_checks_stand_on_the_same_ankle():
    """A walk whose left ankle is planted and right ankle swings: the floor's estimate and the checks both take the
    left ankle as the one standing."""
    T = 60
    joints = np.zeros((1, T, 17, 3))
    joints[0, :, ANKLES[1]] = [0.0, 0.0, 0.1]  # left: planted
    joints[0, :, ANKLES[0], 1] = np.linspace(0.0, 0.5, T)  # right: swinging forward, above the left
    joints[0, :, ANKLES[0], 2] = 0.1 + 0.1 * np.sin(np.linspace(0.0, np.pi, T)) + 0.01
    points = stance_points(joints, 30.0)[0]
    assert len(points) == T and np.allclose(points, [0.0, 0.0, 0.1])
    standing = stance_ankles(joints, None, 30.0, min_stance=0.0)[0]  # (T, 2)
    assert standing[:, 1].all() and not standing[:, 0].any()
