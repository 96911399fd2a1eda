"""Issue 30 (round two of bad inputs): job names stay inside --out, calibrations, pickles and prior configs are
bounded, Ray addresses checked with a deadline, a half-switched output set and --resume's blind spots. Each test
failed before its fix (damaged results, importers and sync: test_bad_inputs_round2_takes.py)."""

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
    port, stop = _server(b"\x00\x00\x00\x04\x00\x00\x00\x00\x00")  # an HTTP/2 greeting alone is not Ray (round 3)
    with pytest.raises(InputError, match="answers but not as a Ray cluster"):
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
