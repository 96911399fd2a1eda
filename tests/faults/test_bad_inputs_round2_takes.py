"""Issue 30, round two of bad inputs (continued): damaged results, importers' absurd values, sync offsets, views at
other frame rates or swapped, the smaller cases. Each test failed before its fix."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

from platypose.lifting.errors import InputError

CALIB = Path(__file__).parents[1] / "data/calib"


def _rewritten(source, path, **changes) -> Path:
    """The result npz ``source`` with fields replaced (arrays, or raw ``.npy`` bytes), written to ``path``."""
    import zipfile

    with zipfile.ZipFile(source) as archive, zipfile.ZipFile(path, "w") as out:
        for info in archive.infolist():
            key = info.filename[:-4]
            if key not in changes:
                out.writestr(info.filename, archive.read(info))
                continue
            value = changes[key]
            if not isinstance(value, bytes):
                buffer = __import__("io").BytesIO()
                __import__("numpy").lib.format.write_array(buffer, value)
                value = buffer.getvalue()
            out.writestr(info.filename, value)
    return path


@pytest.fixture(scope="module")
def result_npz(data_dir, tmp_path_factory) -> Path:
    from export_helpers import two_person_result

    from platypose.exporters.npz import write_npz

    return write_npz(two_person_result(data_dir), tmp_path_factory.mktemp("result") / "take.npz")


def test_damaged_results_are_refused_by_info_and_export(run_cli, result_npz, tmp_path) -> None:
    import numpy as np

    from platypose.exporters.npz import read_npz

    good = read_npz(result_npz)
    P, N, T = good.hypotheses.shape[:3]
    huge_header = (
        b"\x93NUMPY\x01\x00v\x00"
        + ("{'descr': '<f4', 'fortran_order': False, 'shape': (%d, %d, %d, 17, 3), }" % (P, N, 10**9))
        .ljust(117)
        .encode()
        + b"\n"
        + b"\x00" * 64
    )
    deep_meta = np.array("[" * 100_000 + "]" * 100_000)
    cases = {
        "inf": (
            {"hypotheses": np.full_like(good.hypotheses, np.inf), "median": np.full_like(good.median, np.inf)},
            "infinite coordinates",
        ),
        "far": ({"hypotheses": good.hypotheses * 1e30, "median": good.median * 1e30}, "m from the origin"),
        "header": ({"hypotheses": huge_header}, "GiB"),
        "meta": ({"meta": deep_meta}, "nested too deeply"),
    }
    for name, (changes, needle) in cases.items():
        bad = _rewritten(result_npz, tmp_path / f"{name}.npz", **changes)
        for command in (("info", str(bad)), ("export", str(bad), "--formats", "bvh", "--out", str(tmp_path / name))):
            code, _, err = run_cli(*command)
            assert code == 2 and needle in err and len(err.strip().splitlines()) == 1, (name, command, err)
        assert not (tmp_path / name).exists() or not list((tmp_path / name).iterdir())
    code, _, err = run_cli("info", str(result_npz))  # the undamaged result still reads
    assert code == 0, err


def _vicon_with(tmp_path, name: str, **attributes) -> Path:
    """The real Vicon .xcp with the first video camera's attributes (its own or its KeyFrame's) replaced."""
    import xml.etree.ElementTree as ET

    tree = ET.parse(CALIB / "vicon/opencap_testCalibration.xcp")
    camera = next(c for c in tree.getroot().findall("Camera") if "VIDEO" in c.attrib.get("TYPE", "").upper())
    key = camera.find("KeyFrames/KeyFrame")
    for attribute, value in attributes.items():
        (camera if attribute in camera.attrib else key).set(attribute, value)
    path = tmp_path / f"{name}.xcp"
    tree.write(path)
    return path


def _qualisys_scaled(tmp_path, scale: float) -> Path:
    """The real Qualisys file with every camera position multiplied by ``scale`` (1/1000: a file in metres)."""
    import xml.etree.ElementTree as ET

    tree = ET.parse(CALIB / "pose2sim_demo.qca.txt")
    for transform in tree.getroot().iter("transform"):
        for axis in ("x", "y", "z"):
            transform.set(axis, repr(float(transform.get(axis)) * scale))
    path = tmp_path / f"scaled{scale:g}.qca.txt"
    tree.write(path)
    return path


def test_importers_refuse_absurd_values(run_cli, tmp_path) -> None:
    import re

    from platypose.lifting.calibration import load_calibration

    cases = [
        (_vicon_with(tmp_path, "tiny_focal", FOCAL_LENGTH="1e-300"), "focal length"),
        (_vicon_with(tmp_path, "huge_sensor", SENSOR_SIZE="1e200 1e200"), "pixel counts up to"),
        (_vicon_with(tmp_path, "huge_radial", VICON_RADIAL2="Vicon3Parameter 960 540 1e10 1e10 1e10"), "distortion"),
        (_qualisys_scaled(tmp_path, 1e-3), "within"),
        (_qualisys_scaled(tmp_path, 0.0), "within 0.0 mm"),
    ]
    qualisys = (CALIB / "pose2sim_demo.qca.txt").read_text()
    huge = tmp_path / "huge_focal.qca.txt"
    huge.write_text(re.sub(r'focalLengthU="[^"]*"', 'focalLengthU="1e308"', qualisys, count=1))
    cases.append((huge, "focal length"))
    freemocap = (CALIB / "freemocap_test_data_camera_calibration.toml").read_text()
    one_point = tmp_path / "one_point.toml"
    one_point.write_text(re.sub(r"translation = \[[^\]]*\]", "translation = [ 0.0, 0.0, 0.0,]", freemocap))
    cases.append((one_point, "within 0.0 mm"))
    distorted = tmp_path / "distorted.toml"
    distorted.write_text(re.sub(r"distortions = \[[^\]]*\]", "distortions = [ 1e9, 0.0, 0.0, 0.0, 0.0,]", freemocap))
    cases.append((distorted, "distortion"))
    deep = tmp_path / "deep.json"
    deep.write_text("[" * 100_000 + "]" * 100_000)
    cases.append((deep, "not valid JSON"))
    deep_toml = tmp_path / "deep.toml"
    deep_toml.write_text("a = " + "[" * 100_000 + "]" * 100_000)
    cases.append((deep_toml, "not valid TOML"))
    for path, needle in cases:
        with pytest.raises(InputError, match=re.escape(needle)):
            load_calibration(path)
        code, _, err = run_cli("calib", "check", str(path))
        assert code == 2 and needle in err and len(err.strip().splitlines()) == 1, (path.name, err)
    for real in (
        "vicon/opencap_testCalibration.xcp",
        "pose2sim_demo.qca.txt",
        "freemocap_test_data_camera_calibration.toml",
    ):
        assert load_calibration(CALIB / real).cameras  # the real files still load


TAKE = "video/pose2sim-balancing"


@pytest.fixture(scope="module")
def take_views(data_dir):
    """The bundled take's cameras, tracks (OpenPose, 60 fps) and each view's main person."""
    from platypose.detectors.openpose import read_openpose_folder
    from platypose.lifting.calibration import load_calibration

    cal = load_calibration(data_dir / TAKE / "calib_pose2sim.toml")
    folders = [data_dir / TAKE / "openpose-body25b" / f"cam0{i}_json" for i in range(1, 5)]
    tracks = [read_openpose_folder(f, fps=60, image_size=c.size) for f, c in zip(folders, cal.cameras)]
    return cal.cameras, tracks


def _sync(choice, cameras, keypoints, times):
    from platypose.lifting.sync.choice import synchronise

    warnings: list[str] = []
    synced = synchronise(choice, keypoints, times, cameras, lambda _: None, warnings.append)
    return synced, warnings


def test_sync_offsets_bounded_and_still_or_short_views_warned(run_cli, data_dir, take_views, tmp_path) -> None:
    import numpy as np

    cameras, tracks = take_views
    keypoints, times = [t.keypoints for t in tracks], [t.frame_times for t in tracks]
    for offsets, needle in (
        ({"cam01": 0, "cam02": 1e4, "cam03": 0, "cam04": 0}, "shares no time with"),
        ({"cam01": 0, "cam02": 1e6, "cam03": 0, "cam04": 0}, "at most 86400"),
        ({"cam01": 0, "cam02": 10**400, "cam03": 0, "cam04": 0}, "finite numbers of seconds"),
    ):
        path = tmp_path / "offsets.json"
        path.write_text(__import__("json").dumps(offsets))
        with pytest.raises(InputError, match=needle):
            _sync(offsets, cameras, keypoints, times)
        code, _, err = run_cli(
            "calib", "check", str(data_dir / TAKE / "calib_pose2sim.toml"), "--keypoints",
            str(data_dir / TAKE / "openpose-body25b"), "--fps", "60", "--sync", str(path),
        )  # fmt: skip
        assert code == 2 and needle in err and len(err.strip().splitlines()) == 1, err
    rng = np.random.default_rng(0)
    still = np.repeat(keypoints[1][:1], len(keypoints[1]), axis=0)
    still[..., :2] += rng.normal(0.0, 1.0, still[..., :2].shape)  # a frozen view: detector jitter only
    synced, warnings = _sync("auto", cameras, [keypoints[0], still, *keypoints[2:]], times)
    assert synced.confidence[1] == 0.0 and any("cam_02: the person barely moves" in w for w in warnings), warnings
    _, warnings = _sync("auto", cameras, keypoints, times)
    assert not [w for w in warnings if "barely moves" in w or "s of frames" in w]  # the real take moves for 1.7 s
    _, warnings = _sync("auto", cameras, [k[:60] for k in keypoints], [t[:60] for t in times])
    assert any("only 1.0 s of frames" in w for w in warnings), warnings
    broken = tmp_path / "broken.json"
    broken.write_text("{oops")
    with pytest.raises(InputError, match="not valid JSON"):
        _sync(str(broken), cameras[:1], keypoints[:1], times[:1])


def test_views_at_different_frame_rates_are_refused(data_dir, take_views) -> None:
    from platypose.detectors.openpose import read_openpose_folder
    from platypose.detectors.take import take_keypoints

    cameras, tracks = take_views
    slow = read_openpose_folder(data_dir / TAKE / "openpose-body25b/cam02_json", fps=30, image_size=cameras[1].size)
    assert take_keypoints(tracks[:2], cameras[:2])[0].shape[0] == 2
    with pytest.raises(InputError, match=r"different frame rates \(60, 30 fps\)"):
        take_keypoints([tracks[0], slow], cameras[:2], source="take")


def test_swapped_cameras_warned_and_views_judged_by_persons_seen_well(take_views) -> None:
    import numpy as np

    from platypose.detectors.take import take_keypoints
    from platypose.detectors.view_agreement import disagreeing_views
    from platypose.lifting.tracks.persons import reprojection_report
    from platypose.lifting.triangulation import triangulate

    cameras, tracks = take_views
    names = [c.name for c in cameras]
    keypoints, _, _ = take_keypoints(tracks, cameras)
    assert disagreeing_views(keypoints, names) is None  # the real rig
    swapped, _, _ = take_keypoints([tracks[2], tracks[1], tracks[0], tracks[3]], cameras)
    warning = disagreeing_views(swapped, names)
    assert warning and "cam_01 (0%)" in warning and "cam_03 (0%)" in warning and "swapped" in warning, warning
    # the correct rig, plus a far person cam_02 alone sees in 7 of 100 frames, 300 px off wherever it is lifted
    points = triangulate(keypoints[..., :2], keypoints[..., 2], cameras).transpose(1, 0, 2, 3)  # (P, T, 17, 3)
    extra = np.zeros(keypoints.shape[:2] + (1, 17, 3))
    extra[1, :7, 0] = keypoints[1, :7, 0]
    extra[1, :7, 0, :, 0] += 300.0
    median = np.concatenate([points, points[:1]])  # (P + 1, T, 17, 3)
    report, warnings = reprojection_report(median, np.concatenate([keypoints, extra], axis=2), cameras)
    assert report["cam_02"] < 20 and not [w for w in warnings if "cam_02" in w], (report, warnings)


def test_calibration_names_matching_no_video_are_one_error(run_cli, data_dir, tmp_path, prior_file, batch_folder):
    folder = tmp_path / "in"
    folder.mkdir()
    for name in ("front.mp4", "side.mp4", "back.mp4", "top.mp4"):
        (folder / name).symlink_to(batch_folder / "good.mp4")
    code, out, err = run_cli(
        "lift", str(folder), "--cams", str(data_dir / TAKE / "calib_pose2sim.toml"), "--prior", prior_file,
        "--out", str(tmp_path / "out"), "--quiet",
    )  # fmt: skip
    assert code == 2 and len(err.strip().splitlines()) == 1, err
    assert "no camera matches a view by name" in err and "name each video" in err and "cam_01.mp4" in err
    assert not (tmp_path / "out").exists()


def test_smaller_round_two_cases(run_cli, monkeypatch, data_dir, tmp_path) -> None:
    import signal
    import sys
    import types

    from platypose.cli import lift_ray
    from platypose.lifting.floor import parse_floor

    for spec in ("0,0,-1,0", "1,0,0,0", "0,0,1,1e9"):
        with pytest.raises(InputError, match="normal points up"):
            parse_floor(spec)
    assert parse_floor("0,0.1,1,0").normal[2] > 0.99  # a slightly tilted floor is fine
    motion = str(data_dir / "motion/deepmimic")
    read_only = tmp_path / "ro"
    read_only.mkdir()
    read_only.chmod(0o500)
    for options, needle in (
        (["--noise-px", "nan"], "--noise-px nan"),
        (["--noise-px", "-5"], "--noise-px -5"),
        (["--views", "0"], "--views 0"),
        (["--json", str(read_only / "x" / "table.json")] if os.geteuid() else ["--json", str(tmp_path)], "error:"),
    ):
        code, _, err = run_cli("eval", motion, *options)
        assert code == 2 and needle in err and len(err.strip().splitlines()) == 1, (options, err)
    read_only.chmod(0o700)
    code, _, err = run_cli("calib", "check", str(tmp_path / "no\nerror: forged.toml"))
    assert code == 2 and len(err.strip().splitlines()) == 1 and "no?error: forged" in err, err

    def fake_init(**_):  # as Ray's driver does: its own SIGTERM handler
        signal.signal(signal.SIGTERM, lambda *a: sys.exit(1))

    fake = types.SimpleNamespace(is_initialized=lambda: False, init=fake_init, shutdown=lambda: None)
    monkeypatch.setattr(lift_ray, "import_ray", lambda: fake)
    monkeypatch.setattr(lift_ray, "check_ray_address", lambda address: None)
    ours = signal.signal(signal.SIGTERM, signal.default_int_handler)
    try:
        with lift_ray.connected(lift_ray.RayOptions(), quiet=True):
            assert signal.getsignal(signal.SIGTERM) is signal.default_int_handler
    finally:
        signal.signal(signal.SIGTERM, ours)


def test_calibration_numbers_too_large_for_a_float(run_cli, tmp_path) -> None:
    import re

    freemocap = (CALIB / "freemocap_test_data_camera_calibration.toml").read_text()
    path = tmp_path / "bigint.toml"
    path.write_text(
        re.sub(r"translation = \[[^\]]*\]", "translation = [ " + "9" * 400 + ", 0.0, 0.0,]", freemocap, count=1)
    )
    code, _, err = run_cli("calib", "check", str(path))
    assert code == 2 and "non-finite" in err and len(err.strip().splitlines()) == 1, err
