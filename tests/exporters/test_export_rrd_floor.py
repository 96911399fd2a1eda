"""The floor and plausibility in a rerun recording, read back with rerun's own reader."""

from __future__ import annotations

import numpy as np
from export_helpers import read_entities

from platypose.exporters import rerun_adapter as rra
from platypose.exporters.rrd_floor import GRID_EXTENT, log_floor_and_plausibility


def test_floor_grid_and_flags_are_in_the_recording(tmp_path):
    path = tmp_path / "floor.rrd"
    rec = rra.open_recording(path, "platypose", "floor", rra.Layout("world", (), 1, (), (), None, 30.0))
    floor = {"normal": [0.0, 0.0, 1.0], "offset_m": -0.5, "source": "given"}  # z = 0.5
    said = "under floor (20% of hypothesis-frames more than 3 cm under it)"
    reports = [{"frames": 10, "under_floor_share": 0.2, "flags": ["under floor"], "flag_text": said}, {"flags": []}]
    log_floor_and_plausibility(rec, floor, reports, [3, 7], np.array([1.0, 2.0, 1.4]))
    rra.close_recording(rec)
    entities = read_entities(path)
    strips = entities["/world/floor"]["static:LineStrips3D:strips"][0]
    points = np.array([p for strip in strips for p in strip])
    assert len(strips) == 2 * (int(2 * GRID_EXTENT / 0.5) + 1)
    assert np.allclose(points[:, 2], 0.5)  # on the plane
    assert np.allclose(points[:, :2].mean(axis=0), [1.0, 2.0], atol=1e-6)  # about the people
    text = entities["/world/people/p3/plausibility"]["static:TextDocument:text"][0][0]
    assert f"flagged: {said}" in text and '"under_floor_share": 0.2' in text
    assert "flagged: none" in entities["/world/people/p7/plausibility"]["static:TextDocument:text"][0][0]
