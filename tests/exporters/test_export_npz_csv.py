"""npz and CSV exports, read back with np.load, the csv module and pandas, on real climbing motion."""

from __future__ import annotations

import csv
import json

import numpy as np
import pytest
from export_helpers import two_person_result

from platypose.exporters.csv_export import PEOPLE_COLUMNS, write_long_csv, write_people_csv
from platypose.exporters.export import export
from platypose.exporters.npz import read_npz, write_npz
from platypose.exporters.result import LiftResult
from platypose.lifting.errors import InputError
from platypose.lifting.skeleton import JOINT_NAMES, PARENTS


@pytest.fixture(scope="module")
def result(data_dir):
    return two_person_result(data_dir)


def test_npz_has_every_field_and_reads_back(result, tmp_path):
    path = write_npz(result.with_meta(bvh_fit_error={"0": {"mean_m": 0.004}}), tmp_path / "clip.npz")
    with np.load(path, allow_pickle=False) as raw:
        assert {
            "hypotheses",
            "median",
            "keypoints2d",
            "frame_times",
            "fps",
            "joint_names",
            "parents",
            "track_ids",
            "cameras",
            "units",
            "up_axis",
            "meta",
            "energy",
        } <= set(raw.files)
        assert raw["hypotheses"].dtype == np.float32 and raw["hypotheses"].shape == (2, 6, 30, 17, 3)
        np.testing.assert_array_equal(raw["hypotheses"], result.hypotheses)
        np.testing.assert_array_equal(raw["keypoints2d"], result.keypoints2d)
        assert list(raw["joint_names"]) == list(JOINT_NAMES) and raw["parents"].tolist() == list(PARENTS)
        assert str(raw["units"]) == "m" and str(raw["up_axis"]) == "z"
        meta = json.loads(str(raw["meta"]))
        assert meta["prior_sha256"] == "0" * 64 and meta["bvh_fit_error"]["0"]["mean_m"] == 0.004
        calib = json.loads(str(raw["cameras"]))
        assert calib["format"] == "platypose-calib" and [c["name"] for c in calib["cameras"]] == ["cam01", "cam02"]
        np.testing.assert_allclose(calib["cameras"][1]["R"], result.cameras[1].R)
    back = read_npz(path)
    np.testing.assert_array_equal(back.median, result.median)
    np.testing.assert_array_equal(back.energy, result.energy)
    assert back.track_ids.tolist() == [0, 7] and back.fps == result.fps
    assert back.cameras[0].name == "cam01" and np.allclose(back.cameras[0].K, result.cameras[0].K)
    assert back.present()[1].tolist() == [False] * 5 + [True] * 25


def test_read_npz_rejects_damaged_files(result, tmp_path):
    good = write_npz(result, tmp_path / "good.npz")
    with np.load(good) as raw:
        fields = dict(raw)
    fields["median"] = fields["median"][:, :-1]
    np.savez(tmp_path / "short.npz", **fields)
    with pytest.raises(InputError, match=r"short\.npz: median must be"):
        read_npz(tmp_path / "short.npz")
    del fields["meta"]
    np.savez(tmp_path / "nometa.npz", **fields)
    with pytest.raises(InputError, match=r"nometa\.npz: .*missing fields meta"):
        read_npz(tmp_path / "nometa.npz")
    (tmp_path / "text.npz").write_text("not a zip")
    with pytest.raises(InputError, match=r"text\.npz"):
        read_npz(tmp_path / "text.npz")
    with pytest.raises(InputError, match="no such file"):
        read_npz(tmp_path / "missing.npz")


def test_unserialisable_meta_leaves_no_file(result, tmp_path):
    with pytest.raises(InputError, match="meta is not JSON"):
        write_npz(result.with_meta(bad=object()), tmp_path / "clip.npz")
    assert list(tmp_path.iterdir()) == []


def test_long_csv_holds_the_npz_numbers(result, tmp_path):
    path = write_long_csv(result, tmp_path / "clip.csv")
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    assert rows[0] == ["person", "hypothesis", "frame", "time_s", "joint", "x_m", "y_m", "z_m", "filled"]
    body = rows[1:]
    # both persons: 6 hypotheses x 30 frames x 17 joints; person 7's absent frames 0-4 held, filled 1
    assert len(body) == 2 * 6 * 30 * 17
    present = result.present()
    for row in body[:: len(body) // 97]:
        p = {0: 0, 7: 1}[int(row[0])]
        n, t, j = int(row[1]), int(row[2]), JOINT_NAMES.index(row[4])
        assert float(row[3]) == result.frame_times[t]
        assert row[8] == str(int(not present[p, t]))
        if present[p, t]:
            assert np.array_equal(np.float32([float(v) for v in row[5:8]]), result.hypotheses[p, n, t, j])
    held = [r for r in body if r[0] == "7" and r[1] == "2" and int(r[2]) < 5 and r[4] == "head"]
    assert [r[8] for r in held] == ["1"] * 5
    assert all(np.array_equal(np.float32([float(v) for v in r[5:8]]), result.hypotheses[1, 2, 5, 10]) for r in held)


def test_people_csv_has_each_joints_answer_and_spread_per_frame(result, tmp_path):
    path = write_people_csv(result, tmp_path / "clip.csv")
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    assert len(rows) == 2 * 30  # one row per person and frame
    assert list(rows[0])[:8] == ["person", "frame", "time_s", "filled", "pelvis_x_m", "pelvis_y_m", "pelvis_z_m"] + [
        "pelvis_r90_m"
    ]
    assert list(rows[0]) == list(PEOPLE_COLUMNS) and len(PEOPLE_COLUMNS) == 4 + 17 * 4
    present = result.present()
    for row in rows[::7]:
        p, t = {0: 0, 7: 1}[int(row["person"])], int(row["frame"])
        assert row["filled"] == str(int(not present[p, t])) and float(row["time_s"]) == round(result.frame_times[t], 6)
        t = max(t, 5) if p == 1 else t  # person 7's frames 0-4 hold frame 5
        for j, joint in enumerate(JOINT_NAMES):
            answer = np.array([float(row[f"{joint}_{a}_m"]) for a in "xyz"])
            np.testing.assert_allclose(answer, result.median[p, t, j], atol=5e-4 + 1e-9)  # millimetres
            distances = np.linalg.norm(result.hypotheses[p, :, t, j] - result.median[p, t, j], axis=-1)
            assert float(row[f"{joint}_r90_m"]) == pytest.approx(np.quantile(distances, 0.9), abs=5e-4 + 1e-9)
    assert all(len(value.split(".")[-1]) <= 3 for row in rows for k, value in row.items() if k.endswith("_m"))


def test_pandas_reads_the_people_csv_in_one_call_and_the_long_form_is_on_request(result, tmp_path):
    import pandas  # the test extra's; the question is what a pandas user gets from one call

    written = export(result, tmp_path, "clip", ["csv"])
    assert sorted(p.name for p in written) == ["clip.csv", "clip_gaps.json"]  # no file of every hypothesis
    table = pandas.read_csv(tmp_path / "clip.csv")
    assert table.shape == (60, 72) and table["person"].tolist() == [0] * 30 + [7] * 30
    assert all(str(table[c].dtype) == "float64" for c in PEOPLE_COLUMNS[4:])
    ankle = table.loc[table.person == 7, "left_ankle_z_m"].to_numpy()
    np.testing.assert_allclose(ankle[5:], result.median[1, 5:, 6, 2], atol=5e-4 + 1e-9)
    written = export(result, tmp_path / "long", "clip", ["csv-long"])
    assert sorted(p.name for p in written) == ["clip_gaps.json", "clip_hypotheses.csv"]
    assert (tmp_path / "long" / "clip_hypotheses.csv").read_bytes() == write_long_csv(
        result, tmp_path / "direct.csv"
    ).read_bytes()
    long = pandas.read_csv(tmp_path / "long" / "clip_hypotheses.csv")
    assert long.shape == (2 * 6 * 30 * 17, 9) and long["hypothesis"].max() == 5


def test_cameras_are_the_native_calibration_json(result, tmp_path):
    from platypose.lifting.calibration.native import read_native

    path = write_npz(result, tmp_path / "clip.npz")
    with np.load(path) as raw:
        (tmp_path / "calib.json").write_text(str(raw["cameras"]))
    calibration = read_native(tmp_path / "calib.json")  # the calibration engineer's reader
    assert calibration.names == ("cam01", "cam02")
    np.testing.assert_array_equal(calibration.cameras[1].t, result.cameras[1].t)


def test_a_result_needs_a_camera(result):
    with pytest.raises(ValueError, match="at least one camera"):
        LiftResult(
            result.hypotheses,
            result.median,
            result.keypoints2d[:0],
            result.frame_times,
            result.fps,
            result.track_ids,
            cameras=(),
        )
