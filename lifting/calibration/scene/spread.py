"""How far the scene's lines fix the camera: a bootstrap over the physical lines, choosing afresh among the
solutions found.

A fit's own standard deviations say how well the lines fix the camera inside its basin, not whether another
basin explains the lines nearly as well (a person's mask hiding the back wall can leave two self-consistent
scenes, focal lengths a third apart). So each replica weighs the physical lines afresh (a Bayesian bootstrap:
independent exponential weights, so no replica loses a direction's few lines altogether; the pieces of one edge,
cut by a person or split by the detector, are one line and share a weight), refits every solution to the
weighted lines and keeps the one that explains the most of their length
(:func:`platypose.lifting.calibration.scene.manhattan.explained`). The replicas' spread is the uncertainty: it
is wide where the weights decide the basin.
"""

from __future__ import annotations

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from platypose.lifting.calibration.scene import manhattan
from platypose.lifting.calibration.scene.lines import Lines

REPLICAS = 30
SAME_LINE_DEG = 1.0  # pieces of one physical line: directions this close...
SAME_LINE_OFFSET = 0.004  # ...and each middle this near the other's line (normalised units)
SEED = 0


def physical_lines(lines: Lines) -> np.ndarray:
    """Which physical line (N,) each segment is a piece of: segments running within ``SAME_LINE_DEG`` of each other
    whose middles lie within ``SAME_LINE_OFFSET`` of each other's line share a number."""
    parallel = np.abs(lines.direction @ lines.direction.T) >= np.cos(np.radians(SAME_LINE_DEG))
    ones = np.ones((len(lines), 1))
    distance = np.abs(np.hstack([lines.middle, ones]) @ lines.normal.T) / np.maximum(
        np.linalg.norm(lines.normal[:, :2], axis=1), 1e-12
    )  # (i, j): middle i from line j
    same = parallel & (distance <= SAME_LINE_OFFSET) & (distance.T <= SAME_LINE_OFFSET)
    i, j = np.nonzero(same)
    graph = coo_matrix((np.ones(len(i)), (i, j)), shape=(len(lines), len(lines)))
    return connected_components(graph, directed=False)[1]


def bootstrap(lines: Lines, solutions: list[np.ndarray], replicas: int = REPLICAS) -> np.ndarray:
    """The camera (R, 4) (pitch, roll, yaw, log focal) each of ``replicas`` reweighings of the physical lines
    chooses: every solution's params (4,) refitted to the weighted lines, the one explaining the most of them kept."""
    groups = physical_lines(lines)
    count = int(groups.max()) + 1
    rng = np.random.default_rng(SEED)
    chosen = []
    for _ in range(replicas):
        counts = rng.exponential(1.0, count)[groups]
        fits = [manhattan.refit(lines, start, counts) for start in solutions]
        scores = [manhattan.explained(lines, f.params, counts) for f in fits]
        chosen.append(fits[int(np.argmax(scores))].params)
    return np.array(chosen).reshape(-1, 4)


def spread_of(samples: np.ndarray) -> np.ndarray:
    """Standard deviations (4,) of bootstrap params (R, 4); the yaw's on its quarter turn (a square scene's
    directions are the same every 90 degrees)."""
    centred = samples - samples[0]
    centred[:, 2] = (centred[:, 2] + np.pi / 4) % (np.pi / 2) - np.pi / 4
    return centred.std(axis=0)
