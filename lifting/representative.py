"""The one motion a lift exports per person, drawn from its hypotheses (every export carries it).

Scored by its own pelvis-relative error (``platypose eval``'s "answer" columns), the best single answer is
the per-joint middle of the hypotheses' poses: the median pose, taken around each hypothesis's own pelvis
so that where a hypothesis stands (its depth, from one camera) does not smear its pose, with the pelvis at
the hypotheses' median position.
"""

from __future__ import annotations

import numpy as np


def median_motion(hypotheses: np.ndarray) -> np.ndarray:
    """The single answer ``(T, 17, 3)`` of hypotheses ``(N, T, 17, 3)``: median pelvis plus median pelvis-relative pose.

    A frame the hypotheses lack (NaN: the person is absent) stays NaN.
    """
    pelvis = hypotheses[..., :1, :]
    return np.median(pelvis, axis=0) + np.median(hypotheses - pelvis, axis=0)
