"""Adult limb lengths: the range one camera's hypotheses are held to (one view cannot measure a bone).

Segment lengths as fractions of stature H from Drillis & Contini (1966), as tabulated in D. A. Winter,
*Biomechanics and Motor Control of Human Movement* (4th ed., 2009, Fig. 4.1): thigh (hip to knee) 0.245 H,
leg (knee to ankle) 0.246 H, upper arm (shoulder to elbow) 0.186 H, forearm (elbow to wrist) 0.146 H.
Adult stature from the 5th percentile of women to the 95th of men: 1.50-1.90 m. Mocap joint centres sit
a little off the table's landmarks (the CMU wrist is the end of the radius: forearms of 0.19 m in
our training data), so each range is widened by ``DEFINITION_MARGIN`` on either side.
"""

from __future__ import annotations

import numpy as np

from platypose.lifting.skeleton import BONES, JOINT_INDEX

STATURE_RANGE_M = (1.50, 1.90)
DEFINITION_MARGIN = 0.1
# (child, parent) -> fraction of stature
SEGMENT_FRACTIONS: dict[tuple[str, str], float] = {
    **{(f"{s}_knee", f"{s}_hip"): 0.245 for s in ("left", "right")},
    **{(f"{s}_ankle", f"{s}_knee"): 0.246 for s in ("left", "right")},
    **{(f"{s}_elbow", f"{s}_shoulder"): 0.186 for s in ("left", "right")},
    **{(f"{s}_wrist", f"{s}_elbow"): 0.146 for s in ("left", "right")},
}


def adult_limb_ranges() -> dict[int, tuple[float, float]]:
    """Index into BONES -> (shortest, longest) adult length in metres of each limb bone of the table."""
    low, high = STATURE_RANGE_M
    return {
        BONES.index((JOINT_INDEX[child], JOINT_INDEX[parent])): (
            fraction * low * (1 - DEFINITION_MARGIN),
            fraction * high * (1 + DEFINITION_MARGIN),
        )
        for (child, parent), fraction in SEGMENT_FRACTIONS.items()
    }


def clamp_to_adult(lengths: np.ndarray) -> np.ndarray:
    """Bone lengths ``(..., 16)`` with every limb bone of the table held inside its adult range."""
    out = np.array(lengths, np.float64, copy=True)
    for bone, (shortest, longest) in adult_limb_ranges().items():
        out[..., bone] = np.clip(out[..., bone], shortest, longest)
    return out
