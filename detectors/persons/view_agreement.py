"""Whether a take's views see the same people: the sign of cameras swapped between calibration and videos.

After persons are matched across views (:mod:`platypose.detectors.persons.multiview`), a person one view sees is usually
seen by another view in the same frame. When a view's video is paired with another camera's calibration, its
detections triangulate with nobody and stay persons of their own: that view's share of matched detections falls
to about nothing, and the take seems to hold more people than any view shows.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

MIN_MATCHED_SHARE = 0.5  # a view with fewer of its detections seen by another view is reported


def matched_shares(keypoints: np.ndarray) -> np.ndarray:
    """Per view (C,), the share of its detections (frame, person) that another view also sees in that frame;
    ``keypoints`` (C, T, P, 17, 3). NaN for a view without detections."""
    seen = keypoints[..., 2].max(axis=-1) > 0  # (C, T, P)
    shares = np.full(len(seen), np.nan)
    for c in range(len(seen)):
        others = np.delete(seen, c, axis=0).any(axis=0)
        if seen[c].any():
            shares[c] = float((seen[c] & others).sum() / seen[c].sum())
    return shares


def disagreeing_views(keypoints: np.ndarray, names: Sequence[str]) -> str | None:
    """A warning naming the views whose detections mostly match nobody in the other views, or None."""
    if len(names) < 2:
        return None
    shares = matched_shares(keypoints)
    odd = [(name, share) for name, share in zip(names, shares) if share < MIN_MATCHED_SHARE]
    if not odd:
        return None
    listed = ", ".join(f"{name} ({share:.0%})" for name, share in odd)
    return (
        f"views {listed}: few of their detections match a person seen by another view, so the take seems to hold "
        f"{keypoints.shape[2]} person(s); their calibration may belong to other cameras (videos or camera names "
        "swapped?): check with platypose calib check"
    )
