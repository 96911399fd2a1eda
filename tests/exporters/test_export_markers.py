"""TRC and C3D per person, read back by independent readers: a plain text parse, OpenSim's own API, ezc3d."""

from __future__ import annotations

import csv
import dataclasses
import json

import ezc3d
import numpy as np
import pytest
from export_helpers import two_person_result

from platypose.exporters.export import export
from platypose.exporters.markers import MARKER_NAMES


@pytest.fixture(scope="module")
def result(data_dir):
    """Two persons, person 7 absent in frames 0-4 (start) and, here, 12-15 (inside)."""
    r = two_person_result(data_dir)
    hyp, med = np.array(r.hypotheses), np.array(r.median)
    hyp[1, :, 12:16] = np.nan
    med[1, 12:16] = np.nan
    return dataclasses.replace(r, hypotheses=hyp, median=med)


@pytest.fixture(scope="module")
def files(result, tmp_path_factory):
    out = tmp_path_factory.mktemp("markers")
    lines = []
    export(result, out, "clip", ["trc", "c3d"], say=lines.append)
    return out, lines


def opensim_axes(points: np.ndarray) -> np.ndarray:
    """Our Z-up (x, y, z) as Pose2Sim's Y-up TRC axes: (y, z, x)."""
    return points[..., [1, 2, 0]]


def expected_filled(result, p: int) -> np.ndarray:
    """The median of person p with absent frames held at the ends and interpolated inside, in TRC axes."""
    med = np.asarray(result.median[p], np.float64)
    on = np.isfinite(med).all(axis=(1, 2))
    t = result.frame_times
    flat = med[on].reshape(on.sum(), -1)
    filled = np.stack([np.interp(t, t[on], flat[:, k]) for k in range(flat.shape[1])], 1).reshape(med.shape)
    return opensim_axes(filled)


def read_trc(path):
    """A TRC file parsed as plain tab-separated text: header lines and the numeric table."""
    lines = path.read_text().split("\n")
    header = [line.split("\t") for line in lines[:5]]
    table = np.array([[float(v) for v in line.split("\t")] for line in lines[5:] if line.strip()])
    return header, table


def test_trc_header_and_values(result, files):
    out, _ = files
    for p, track in enumerate(result.track_ids):
        path = out / f"clip_p{track}.trc"
        header, table = read_trc(path)
        T = result.num_frames
        assert header[0] == ["PathFileType", "4", "(X/Y/Z)", path.name]
        assert header[1][:5] == ["DataRate", "CameraRate", "NumFrames", "NumMarkers", "Units"]
        assert header[2] == ["120", "120", str(T), "17", "m", "120", "0", str(T)]
        assert header[3][:2] == ["Frame#", "Time"] and header[3][2::3] == list(MARKER_NAMES)
        assert header[4][2:5] == ["X1", "Y1", "Z1"] and header[4][-1] == "Z17"
        assert table.shape == (T, 2 + 17 * 3) and np.isfinite(table).all()
        np.testing.assert_array_equal(table[:, 0], np.arange(T))
        np.testing.assert_allclose(table[:, 1], result.frame_times, atol=1e-6)
        np.testing.assert_allclose(table[:, 2:].reshape(T, 17, 3), expected_filled(result, p), atol=1e-6)
        on = result.present()[p]
        np.testing.assert_allclose(table[on, 2:].reshape(-1, 17, 3), opensim_axes(result.median[p][on]), atol=1e-6)


def test_trc_reads_in_opensim(result, files):
    osim = pytest.importorskip("opensim")
    out, _ = files
    table = osim.TimeSeriesTableVec3(str(out / "clip_p7.trc"))
    assert table.getNumRows() == result.num_frames and list(table.getColumnLabels()) == list(MARKER_NAMES)
    assert table.getTableMetaDataAsString("Units") == "m"
    np.testing.assert_allclose(list(table.getIndependentColumn()), result.frame_times, atol=1e-6)
    want = expected_filled(result, 1)
    for t in (0, 13, 20):
        row = table.getRowAtIndex(t)
        got = np.array([[row[k][i] for i in range(3)] for k in range(17)])
        np.testing.assert_allclose(got, want[t], atol=1e-6)


def test_c3d_reads_in_ezc3d(result, files):
    out, _ = files
    for p, track in enumerate(result.track_ids):
        c3d = ezc3d.c3d(str(out / f"clip_p{track}.c3d"))
        point = c3d["parameters"]["POINT"]
        assert list(point["LABELS"]["value"]) == list(MARKER_NAMES)
        assert point["RATE"]["value"][0] == pytest.approx(result.fps) and point["UNITS"]["value"] == ["mm"]
        assert point["X_SCREEN"]["value"] == ["+Z"] and point["Y_SCREEN"]["value"] == ["+Y"]
        xyz = np.moveaxis(c3d["data"]["points"][:3], 0, -1).transpose(1, 0, 2)  # (T, 17, 3) mm
        np.testing.assert_allclose(xyz / 1000, expected_filled(result, p), atol=1e-6)
        residuals = c3d["data"]["meta_points"]["residuals"][0]  # (17, T)
        on = result.present()[p]
        assert (residuals[:, on] > 0).all() and (residuals[:, ~on] == 0).all()  # 0: interpolated


def test_gaps_are_listed_in_the_sidecar_and_the_log(files):
    out, lines = files
    gaps = json.loads((out / "clip_gaps.json").read_text())["filled_gaps"]
    assert gaps["p0"] == []
    assert [(g["first_frame"], g["last_frame"], g["how"]) for g in gaps["p7"]] == [
        (0, 4, "held"),
        (12, 15, "interpolated"),
    ]
    assert any("person 7" in line and "0-4 held, 12-15 interpolated" in line for line in lines)
    assert any("person 0" in line and "no gap" in line for line in lines)


def test_every_format_fills_a_gap_the_same_way(result, tmp_path):
    """Person 7's interior gap (frames 12-15) in the TRC, the CSV, the BVH and the angles: the same
    interpolated joints (BVH within its fit), marked filled in every table."""
    from bvh import Bvh

    from platypose.exporters.angles import ANGLE_NAMES, joint_angles
    from platypose.exporters.bvh import from_bvh_axes

    export(result, tmp_path, "clip", ["csv", "bvh", "trc", "angles"])
    want = expected_filled(result, 1)  # TRC axes
    _, trc = read_trc(tmp_path / "clip_p7.trc")
    np.testing.assert_allclose(trc[:, 2:].reshape(-1, 17, 3), want, atol=1e-6)
    with open(tmp_path / "clip.csv", newline="") as f:
        rows = [r for r in csv.DictReader(f) if r["person"] == "7"]
    assert [r["filled"] for r in rows[10:17]] == ["0", "0", "1", "1", "1", "1", "0"]
    csv_head = np.array([[float(r[f"head_{a}_m"]) for a in "xyz"] for r in rows])
    np.testing.assert_allclose(opensim_axes(csv_head), want[:, 10], atol=5e-4)  # the people's CSV: millimetres
    frames = np.array(Bvh((tmp_path / "clip_p7.bvh").read_text()).frames, dtype=np.float64)
    root = from_bvh_axes(frames[:, :3])
    np.testing.assert_allclose(opensim_axes(root[12:16]), want[12:16, 0], atol=0.02)
    with open(tmp_path / "clip_angles.csv", newline="") as f:
        knee = [r for r in csv.DictReader(f) if r["person"] == "7" and r["angle"] == "left_knee_flexion"]
    filled = expected_filled(result, 1)[..., [2, 0, 1]]  # back to our axes
    k = ANGLE_NAMES.index("left_knee_flexion")
    np.testing.assert_allclose([float(r["median_deg"]) for r in knee], joint_angles(filled)[:, k], atol=2e-3)
    assert [r["filled"] for r in knee[11:17]] == ["0", "1", "1", "1", "1", "0"]
