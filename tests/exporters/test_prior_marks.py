"""Frames lifted through a detection gap (present, no view sees the person) are marked as filled by the prior in the
recording (the label over the head, the quality text) and in the report picture (grey spans)."""

from __future__ import annotations

import numpy as np
import pytest
from export_helpers import read_entities, two_person_result
from matplotlib.figure import Figure

from platypose.exporters.angles import angle_series
from platypose.exporters.report import write_report
from platypose.exporters.rrd import PRIOR_LABEL, quality_flags, quality_text, write_rrd

UNSEEN = slice(12, 20)  # frames of person p0 (P index 0) no camera sees


@pytest.fixture(scope="module")
def result(data_dir):
    """Two persons on real climbing motion; p0 unseen (no keypoints) in frames 12-19 but lifted there."""
    r = two_person_result(data_dir)
    r.keypoints2d[:, 0, UNSEEN] = 0.0
    return r


def test_the_recording_labels_the_unseen_frames_and_counts_them(result, tmp_path):
    write_rrd(result, tmp_path / "clip.rrd", "clip", {})
    entities = read_entities(tmp_path / "clip.rrd")
    for p, track in enumerate(result.track_ids):
        label = entities[f"/world/people/p{track}/label"]
        by_frame = dict(zip(label["frame"], (row[0] for row in label["Points3D:labels"])))
        assert sorted(by_frame) == np.flatnonzero(result.present()[p]).tolist()  # every present frame labelled
        prior = sorted(f for f, text in by_frame.items() if text.endswith(PRIOR_LABEL))
        assert prior == (list(range(12, 20)) if p == 0 else [])
        assert all(text.startswith(f"p{track}") for text in by_frame.values())
    quality = entities["/quality"]["static:TextDocument:text"][0][0]
    assert "**p0**: present in 30 / 30 frames (8 of them unseen, filled by the prior)" in quality
    assert "**p7**: present in 25 / 30 frames," in quality  # seen wherever present: no such note
    flags = {p: quality_flags(result, p) for p in range(result.num_persons)}
    assert quality_text(result, flags) == quality


def test_the_report_shades_the_unseen_frames(result, tmp_path, monkeypatch):
    drawn = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: drawn.append(self))
    write_report(result, angle_series(result), "clip", tmp_path / "clip_report.png")
    (fig,) = drawn
    shaded = {}
    for ax in fig.axes:
        spans = [patch for patch in ax.patches if patch.get_label() == "unseen: filled by the prior"]
        if spans:
            (span,) = spans
            shaded[ax.get_title()] = (span.get_x(), span.get_x() + span.get_width())  # a rectangle in data x
    times = result.frame_times
    assert len(shaded) == 3 and all(title.startswith("person 0") for title in shaded)  # p7 is seen throughout
    for first, last in shaded.values():
        assert (first, last) == pytest.approx((times[12], times[19]))
