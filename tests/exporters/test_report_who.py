"""The report picture says who each row is about (thumbnail, camera, frame, box), in id order, and what is flagged."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from export_helpers import two_person_result
from matplotlib.figure import Figure

from platypose.exporters.angles import angle_series
from platypose.exporters.person_pictures import GoodFrame
from platypose.exporters.report import write_report


def test_rows_in_id_order_with_who_and_the_flag_sentence(data_dir, tmp_path, monkeypatch):
    result = replace(two_person_result(data_dir), track_ids=np.array([7, 0]))  # P order is not id order
    flagged = {"flags": ["under floor"], "flag_text": "under floor (20% of hypothesis-frames more than 3 cm under it)"}
    result = result.with_meta(plausibility=[{"flags": []}, flagged])  # person 0 (P index 1) is flagged
    drawn = []
    monkeypatch.setattr(Figure, "savefig", lambda self, *a, **k: drawn.append(self))
    frames = {0: GoodFrame(0, 3, (10.0, 20.0, 110.0, 320.0))}  # person 7 (P index 0)
    picture = np.full((160, 60, 3), 90, np.uint8)
    write_report(result, angle_series(result), "clip", tmp_path / "clip_report.png", (frames, {0: picture}))
    (fig,) = drawn
    rows = [ax for ax in fig.axes if ax.get_title().split("\n")[0].endswith("hips and knees")]
    titles = [ax.get_title().split("\n", 1) for ax in rows]
    assert [t[0] for t in titles] == ["person 0: hips and knees", "person 7: hips and knees"]  # id order
    said = [t[1].replace("\n", " ") if len(t) > 1 else "" for t in titles]  # the flags in the title, wrapped
    assert said == [f"flagged: {flagged['flag_text']}", ""]
    assert rows[0].title.get_color() == "tab:red" and rows[1].title.get_color() != "tab:red"
    who = [ax for ax in fig.axes if ax.get_title().startswith("person ") and "hips" not in ax.get_title()]
    who = [ax for ax in who if not any(w in ax.get_title() for w in ("trunk", "pelvis", "ankle"))]
    assert [ax.get_title() for ax in who] == [
        "person 0",
        f"person 7\n{result.cameras[0].name} frame 3\nbox 10,20-110,320 px",
    ]
    assert not who[0].images and who[1].images[0].get_array().shape == (160, 60, 3)
