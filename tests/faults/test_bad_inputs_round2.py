"""Issue 30 (round two of bad inputs): job names stay inside --out, calibrations, pickles and configs are bounded,
damaged results are refused. Each test failed before its fix."""

from __future__ import annotations

import os
import shutil
from pathlib import Path

import pytest

from platypose.cli.lift_jobs import discover_jobs, keypoints_job
from platypose.cli.safe_names import safe_name
from platypose.lifting.errors import InputError

CALIB = Path(__file__).parents[1] / "data/calib"


def _listing(folder):
    return sorted(str(p.relative_to(folder)) for p in folder.rglob("*"))


def test_job_names_are_safe_file_names(data_dir, tmp_path) -> None:
    video = data_dir / "video/pose2sim-balancing/cam01.mp4"
    for name in ("...mp4", "..mp4", ".hidden.mp4", "summary.json.mp4", "a\nerror: forged.mp4"):
        shutil.copy(video, tmp_path / name)
    names = [job.name for job in discover_jobs([tmp_path])]
    assert sorted(names) == sorted(["__", "_", "_hidden", "summary.json_take", "a_error_ forged"]), names
    assert all(safe_name(n) == n for n in names)
    shutil.copy(data_dir / "video/sports2d-demo/movenet-detections.npz", tmp_path / "..npz")
    assert keypoints_job(tmp_path / "..npz", [], ()).name == "_"
    assert safe_name("x" * 300) == "x" * 120 and safe_name("") == "take" and safe_name("a/b\\c") == "a_b_c"


def test_lift_of_dot_dot_stem_writes_only_inside_out(run_cli, tmp_path, prior_file, batch_folder) -> None:
    inputs = tmp_path / "in"
    inputs.mkdir()
    shutil.copy(batch_folder / "good.mp4", inputs / "...mp4")
    shutil.copy(batch_folder / "good.mp4", inputs / "..mp4")
    parent = tmp_path / "parent"
    out = parent / "out"
    parent.mkdir()
    code, _, err = run_cli(
        "lift", str(inputs), "--prior", prior_file, "--out", str(out), "--samples", "2", "--formats", "npz",
        "--quiet", "--threads", "1",
    )  # fmt: skip
    assert code == 0, err
    assert _listing(parent) == sorted(["out"] + [f"out/{p}" for p in _listing(out)])  # nothing beside OUT
    assert not [p for p in out.iterdir() if p.name.startswith(".") and p.name != ".summary.lock"]
    assert (out / "__" / "__.npz").is_file() and (out / "_" / "_.npz").is_file()


def _caliscope_with(path, count: int, source) -> None:
    """The real Caliscope camera_array.toml with its first camera repeated under ``count`` ids."""
    import tomllib

    first = tomllib.loads(source.read_text())["cameras"]["0"]
    body = "\n".join(f"{k} = {v!r}".replace("True", "true").replace("False", "false") for k, v in first.items())
    path.write_text("".join(f"[cameras.{i}]\n{body.replace('cam_id = 0', f'cam_id = {i}')}\n\n" for i in range(count)))


def test_calibration_camera_count_and_file_size_are_bounded(run_cli, data_dir, tmp_path) -> None:
    from platypose.lifting.calibration import load_calibration

    source = CALIB / "caliscope/camera_array.toml"
    many = tmp_path / "many.toml"
    _caliscope_with(many, 2000, source)
    code, _, err = run_cli("calib", "check", str(many))
    assert code == 2 and "2000 cameras; at most 256" in err and len(err.strip().splitlines()) == 1, err
    huge = tmp_path / "huge.toml"
    huge.write_bytes(source.read_bytes() + b"#" * (17 * 2**20))
    with pytest.raises(InputError, match="too large for a calibration file"):
        load_calibration(huge)


class _Reduce:
    """Pickles as the call ``func(*args)``: how a crafted file asks the unpickler for an array."""

    def __init__(self, func, *args, state=None) -> None:
        self.func, self.args, self.state = func, args, state

    def __reduce__(self):
        return (self.func, self.args) if self.state is None else (self.func, self.args, self.state)


def _h36m_file(path, clip) -> Path:
    np = pytest.importorskip("numpy")
    np.savez(path, positions_3d=np.array({"S1": {"Walking": clip}}, dtype=object))
    return path


def test_pickle_resource_bombs_are_refused(data_dir, tmp_path) -> None:
    import numpy as np

    from platypose.lifting.motion_io import load_motion
    from platypose.lifting.motion_io.h36m import load_h36m

    walk = load_motion(data_dir / "motion/cmu-asf-amc/test.amc")[0].joints[:50]
    real = np.zeros((50, 32, 3))
    real[:, :17] = walk
    assert load_h36m(_h36m_file(tmp_path / "ok.npz", real))[0].joints.shape == (50, 17, 3)  # real data still loads
    doubled: list = []
    for _ in range(40):
        doubled = [doubled, doubled]  # 40 lists in the file, 2**40 when walked
    wide: list = [0.0] * 3
    for _ in range(22):
        wide = [wide, wide]  # 22 deep: under the depth bound, 2**22 elements
    reconstruct = np.zeros(1).__reduce__()[0]
    bombs = {
        "deep": doubled,
        "wide": wide,
        "shape": _Reduce(np.ndarray, (2**40,)),
        "reconstruct": _Reduce(reconstruct, np.ndarray, (2**40,), b"b"),
        "setstate": _Reduce(reconstruct, np.ndarray, (0,), b"b", state=(1, (2**40,), np.dtype("f8"), False, b"")),
    }
    for name, clip in bombs.items():
        path = _h36m_file(tmp_path / f"{name}.npz", clip)
        assert path.stat().st_size < 2000
        with pytest.raises(InputError, match=rf"{name}.npz: 'positions_3d'"):
            load_h36m(path)


def _server(reply: bytes):
    """A TCP server on a free local port that answers every connection with ``reply``; (port, stop)."""
    import socket
    import threading

    listener = socket.create_server(("127.0.0.1", 0))
    listener.settimeout(0.2)
    stop = threading.Event()

    def serve() -> None:
        while not stop.is_set():
            try:
                conn, _ = listener.accept()
            except TimeoutError:
                continue
            conn.recv(64)
            conn.sendall(reply)
            conn.close()

    threading.Thread(target=serve, daemon=True).start()
    return listener.getsockname()[1], stop


def _closed_port() -> int:
    import socket

    with socket.create_server(("127.0.0.1", 0)) as probe:
        return probe.getsockname()[1]


def test_ray_address_is_checked_with_a_deadline(run_cli, batch_folder, prior_file, tmp_path) -> None:
    import time

    from platypose.cli.ray_address import check_ray_address

    for bad in ("nonsense", "host:", "ray://:10001", "a b:1", "h:70000"):
        with pytest.raises(InputError, match="not an address"):
            check_ray_address(bad)
    port, stop = _server(b"SSH-2.0-OpenSSH_9.6\r\n")
    with pytest.raises(InputError, match="answers but not as a Ray cluster"):
        check_ray_address(f"127.0.0.1:{port}", timeout_s=2)
    stop.set()
    port, stop = _server(b"\x00\x00\x00\x04\x00\x00\x00\x00\x00")  # a gRPC server's first frame: SETTINGS
    check_ray_address(f"ray://127.0.0.1:{port}", timeout_s=2)
    stop.set()
    started = time.monotonic()
    for address in (f"127.0.0.1:{_closed_port()}", "nonsense"):
        code, _, err = run_cli(
            "lift", str(batch_folder / "good.mp4"), "--prior", prior_file, "--out", str(tmp_path),
            "--executor", "ray", "--ray-address", address, "--quiet",
        )  # fmt: skip
        assert code == 2 and err.startswith("error: --ray-address") and len(err.strip().splitlines()) == 1, err
    assert time.monotonic() - started < 30


def test_a_half_switched_output_set_is_not_taken_as_finished(run_cli, monkeypatch, tmp_path, batch_folder, prior_file):
    import os

    args = ("lift", str(batch_folder / "good.mp4"), "--prior", prior_file, "--out", str(tmp_path), "--quiet")
    old = (*args, "--samples", "2", "--formats", "npz,bvh")
    assert run_cli(*old)[0] == 0
    folder = tmp_path / "good"
    real_replace, moved = os.replace, []

    def killed_after_one(src, dst):  # the re-run dies after moving its first output into place
        if ".partial" in str(src) and ".partial" not in str(dst):
            if moved:
                raise KeyboardInterrupt
            moved.append(dst)
        return real_replace(src, dst)

    monkeypatch.setattr(os, "replace", killed_after_one)
    code, _, _ = run_cli(*args, "--samples", "3", "--formats", "npz,bvh")
    monkeypatch.setattr(os, "replace", real_replace)
    assert code == 130 and len(moved) == 1
    (tmp_path / ".good.999999999.x.partial").mkdir()  # what a SIGKILL leaves
    code, out, err = run_cli(*old, "--resume")
    assert code == 0 and "1 ok, 0 failed, 0 skipped" in out, out + err
    assert not list(tmp_path.glob(".good.*.partial"))
    code, out, _ = run_cli(*old, "--resume")
    assert code == 0 and "0 ok, 0 failed, 1 skipped" in out
    bvh = folder / "good_p0.bvh"
    text = bvh.read_text()
    bvh.write_text(text[:-2] + ("1" if text[-2] != "1" else "2") + text[-1])  # same size, other content
    code, out, _ = run_cli(*old, "--resume")
    assert code == 0 and "1 ok, 0 failed, 0 skipped" in out, out
    (tmp_path / ".good.999999999.y.partial").mkdir()
    code, out, _ = run_cli(*old, "--resume")
    assert "1 skipped" in out and not list(tmp_path.glob(".good.*.partial"))  # skipped, and the leftover removed


def test_resume_fingerprint_sees_runtime_and_keypoints_copied_with_old_times(data_dir, tmp_path) -> None:
    from dataclasses import replace

    from platypose.cli.lift_jobs import keypoints_job
    from platypose.cli.lift_run import RunSettings, fingerprint
    from platypose.lifting.settings import PriorSettings

    folder = tmp_path / "cam01_json"
    shutil.copytree(data_dir / "video/pose2sim-balancing/openpose-body25b/cam01_json", folder)
    job = keypoints_job(folder, [], ())
    settings = RunSettings(out=tmp_path / "out")
    before = fingerprint(job, settings)
    assert fingerprint(job, settings) == before
    assert fingerprint(job, replace(settings, prior=PriorSettings(runtime="bfloat16"))) != before
    files = sorted(folder.iterdir())
    shutil.copy2(files[-1], files[len(files) // 2])  # cp -p: other content, an older time, same count
    assert fingerprint(job, settings) != before


def _edited_prior(source, path, edit) -> str:
    """The checkpoint ``source`` with ``edit(payload)`` applied, saved to ``path``."""
    import torch

    payload = torch.load(source, weights_only=True)
    edit(payload)
    torch.save(payload, path)
    return str(path)


@pytest.mark.parametrize(
    "edit, needle",
    [
        (lambda p: p["config"].update(diffusion_steps=1e9), "diffusion_steps must be a whole number"),
        (lambda p: p["config"].update(diffusion_steps=10**9), "diffusion_steps must be within"),
        (lambda p: p["config"].update(layers=10**6), "layers must be within"),
        (
            lambda p: p["config"].update(width="64"),
            "not a valid platypose prior (width must be a whole number, got '64')",
        ),
        (lambda p: p.update(config=[1, 2]), "not a valid platypose prior"),
        (lambda p: p["manifest"].update(sampling_steps=[10**12, 3]), "sampling_steps must be decreasing"),
        (lambda p: p["manifest"].update(distilled={"x": 1}), "'distilled' is damaged"),
        (lambda p: p["manifest"].update(clips=[{"name": 3}]), "'clips' must list"),
        (lambda p: p["normalizer"].update(mean=[0.0] * 7), "normalisation does not have"),
        (lambda p: p.pop("normalizer"), "not a valid platypose prior (no 'normalizer')"),
    ],
)
def test_prior_config_and_manifest_are_validated(run_cli, prior_file, tmp_path, edit, needle) -> None:
    bad = _edited_prior(prior_file, tmp_path / "bad.pt", edit)
    code, _, err = run_cli("prior-info", bad)
    assert code == 2 and needle in err and len(err.strip().splitlines()) == 1, err
    assert "Error" not in err  # the problem, not the name of a Python exception


def test_distilling_into_the_teacher_is_refused(run_cli, data_dir, prior_file, tmp_path) -> None:
    teacher = tmp_path / "teacher.pt"
    shutil.copy(prior_file, teacher)
    before = teacher.read_bytes()
    (tmp_path / "link.pt").symlink_to(teacher)
    for out in (teacher, tmp_path / "link.pt", tmp_path / "." / "teacher.pt"):
        code, _, err = run_cli(
            "train", str(data_dir / "motion/deepmimic"), "--out", str(out), "--distil-from", str(teacher),
            "--iterations", "1",
        )  # fmt: skip
        assert code == 2 and "is the teacher given by --distil-from" in err, err
    assert teacher.read_bytes() == before


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
    from platypose.lifting.sync_choice import synchronise

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
    from platypose.lifting.take import reprojection_report
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
