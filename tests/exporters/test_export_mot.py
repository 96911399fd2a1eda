"""OpenSim: the platypose17 model, scaling and IK run by OpenSim 4.6 itself, and ``--formats mot``."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest
from export_helpers import two_person_result

from platypose.exporters.export import export
from platypose.exporters.markers import MARKER_NAMES
from platypose.lifting.errors import InputError
from platypose.lifting.skeleton import JOINT_INDEX as J

LIFTS = Path(__file__).parents[1] / "data" / "lifts"


def test_the_model_has_our_markers_on_our_joints():
    """The model's 17 markers are our TRC's names; in the default pose ``Neck`` sits 6.5 cm above ``Thorax`` (our
    neck joint, the head's pivot), not at shoulder level, and ``Head`` 11 cm above it."""
    osim = pytest.importorskip("opensim")
    from platypose.exporters.mot import load_opensim
    from platypose.exporters.opensim_model import build_model

    load_opensim()
    model = build_model(osim)
    state = model.initSystem()
    markers = model.getMarkerSet()
    assert sorted(markers.get(k).getName() for k in range(markers.getSize())) == sorted(MARKER_NAMES)
    at = {n: np.array([markers.get(n).getLocationInGround(state)[k] for k in range(3)]) for n in MARKER_NAMES}
    assert at["Neck"][1] - at["Thorax"][1] == pytest.approx(0.065)
    assert at["Head"][1] - at["Neck"][1] == pytest.approx(0.11)
    assert at["RShoulder"][2] > 0 > at["LShoulder"][2]  # Z right, as our TRC's axes


def test_opensim_scales_the_model_and_runs_ik_on_a_four_view_lift(tmp_path):
    """The Pose2Sim athlete lifted from four views (tests/data/lifts): OpenSim 4.6 scales the model (head 0.8-1.2)
    and fits it with a median marker RMS under 2 cm; knees read 0-140 degrees of flexion, read back by OpenSim's
    own storage reader."""
    osim = pytest.importorskip("opensim")
    from platypose.exporters.mot import load_opensim, person_mot

    load_opensim()
    joints = np.load(LIFTS / "pose2sim_4views_median.npy").astype(np.float64)
    times = np.arange(len(joints)) / 60.0
    fit = person_mot(osim, joints, times, 60.0, tmp_path)
    assert fit.rms_median_m <= 0.02, fit
    assert 0.8 <= fit.scales["head"] <= 1.2, fit
    table = osim.TimeSeriesTable(str(tmp_path / "ik.mot"))
    assert table.getNumRows() == len(joints)
    for knee in ("knee_r_flexion", "knee_l_flexion"):
        values = table.getDependentColumn(knee).to_numpy()
        assert -5.0 <= values.min() and values.max() <= 140.0, (knee, values.min(), values.max())
    ours = np.degrees(
        np.arccos(np.sum(_unit(joints, "right_hip", "right_knee") * _unit(joints, "right_knee", "right_ankle"), -1))
    )
    np.testing.assert_allclose(table.getDependentColumn("knee_r_flexion").to_numpy(), ours, atol=8.0)


def _unit(joints: np.ndarray, a: str, b: str) -> np.ndarray:
    v = joints[:, J[b]] - joints[:, J[a]]
    return v / np.linalg.norm(v, axis=-1, keepdims=True)


def test_export_writes_a_mot_and_model_per_person(data_dir, tmp_path):
    pytest.importorskip("opensim")
    result = two_person_result(data_dir)
    written = export(result, tmp_path, "clip", ["mot", "npz"])
    assert {p.name for p in written} >= {"clip_p0.mot", "clip_p7.mot", "clip_p0.osim", "clip_p7.osim"}
    lines = (tmp_path / "clip_p7.mot").read_text().splitlines()
    header = lines[lines.index("endheader") + 1].split("\t")
    assert header[0] == "time" and "knee_r_flexion" in header and "shoulder_l_rotation" in header
    assert len(lines) - lines.index("endheader") - 2 == result.num_frames
    assert not list(tmp_path.glob("*.log")) and not list(Path.cwd().glob("opensim.log"))


def test_a_missing_opensim_is_one_clear_error(data_dir, tmp_path, monkeypatch, run_cli):
    """Without the extra: InputError naming the install, nothing written; the command exits 2 with one line."""
    monkeypatch.setitem(sys.modules, "opensim", None)  # import opensim raises ImportError
    result = two_person_result(data_dir)
    with pytest.raises(InputError, match=r"pip install 'platypose\[opensim\]'"):
        export(result, tmp_path / "out", "clip", ["npz", "mot"])
    assert not (tmp_path / "out").exists()
    export(result, tmp_path, "clip", ["npz"])
    code, _, err = run_cli("export", str(tmp_path / "clip.npz"), "--formats", "mot", "--out", str(tmp_path / "m"))
    assert code == 2 and err.strip().count("\n") == 0 and "platypose[opensim]" in err, err
    assert not (tmp_path / "m").exists() or not any((tmp_path / "m").iterdir())


def test_the_shipped_files_are_the_built_ones_and_run_in_opensim(data_dir, tmp_path, monkeypatch):
    """data/opensim/ is what tools/build_opensim_model.py writes today; its scale and IK set-ups, loaded by
    OpenSim from the XML in their folder (their file names are relative), run on a TRC of ours put beside them."""
    pytest.importorskip("opensim")
    import shutil
    import subprocess

    from platypose.exporters.mot import load_opensim, read_storage
    from platypose.exporters.trc import write_trc

    tool = Path(__file__).parents[2] / "tools" / "build_opensim_model.py"
    subprocess.run([sys.executable, str(tool), str(tmp_path / "built")], check=True, capture_output=True)
    shipped = data_dir / "opensim"
    for name in ("platypose17.osim", "platypose17_scale.xml", "platypose17_ik.xml"):
        assert (shipped / name).read_text() == (tmp_path / "built" / name).read_text(), name
    osim = load_opensim()
    work = tmp_path / "trial"
    shutil.copytree(shipped, work)
    joints = np.load(LIFTS / "pose2sim_4views_median.npy").astype(np.float64)
    write_trc(joints, np.arange(len(joints)) / 60.0, 60.0, work / "markers.trc")
    monkeypatch.chdir(work)
    osim.ScaleTool(str(work / "platypose17_scale.xml")).run()
    assert (work / "platypose17_scaled.osim").exists()
    osim.InverseKinematicsTool(str(work / "platypose17_ik.xml")).run()
    names, values = read_storage(work / "markers_ik.mot")
    assert len(values) == len(joints) and "neck_flexion" in names


def test_ik_keeps_each_hinge_on_the_branch_the_joints_bend_and_warns_of_a_pinned_one(tmp_path):
    """A one-view lift of the Pose2Sim athlete (tests/data/lifts, before the joint limits). Without a
    hint OpenSim's IK, which starts every frame from the one before, held an elbow on the wrong branch at its
    -20 degree limit (39 degrees from the angles CSV). Hinted, every hinge coordinate lies within 5 degrees
    (median) of our signed flexion, and the hinges our joints bend past -20 are named in the fit's warnings."""
    osim = pytest.importorskip("opensim")
    from platypose.exporters.mot import AT_LIMIT_SHARE, load_opensim, person_mot, read_storage
    from platypose.exporters.opensim_model import HINGE_COORDINATES
    from platypose.lifting.anatomy.hinges import signed_flexion

    load_opensim()
    joints = np.load(LIFTS / "pose2sim_cam01_median.npy").astype(np.float64)
    fit = person_mot(osim, joints, np.arange(len(joints)) / 60.0, 60.0, tmp_path)
    names, values = read_storage(tmp_path / "ik.mot")
    ours = signed_flexion(joints)
    for k, coordinate in enumerate(HINGE_COORDINATES):
        assert np.median(np.abs(values[:, names.index(coordinate)] - ours[:, k])) < 5.0, coordinate
    beyond = {c for k, c in enumerate(HINGE_COORDINATES) if np.mean(ours[:, k] < -21.0) > AT_LIMIT_SHARE}
    assert beyond == {c for c, share in fit.at_limit.items() if share > AT_LIMIT_SHARE}
    assert bool(beyond) == any("at its limit" in w for w in fit.warnings())
