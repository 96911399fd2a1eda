"""Audit of issue 30's bad inputs and their neighbours, run against the installed ``platypose`` command.

Each case runs in a child process under a 3 GB address-space limit and a time limit, in a fresh folder
whose parent is watched. A case counts as: a write outside --out (a file created or changed beside the out
folder), a hang (time limit), a memory blow-up (peak RSS over 2 GB, or MemoryError), a traceback, an internal
exception message (a Python exception name in the output or summary), or a silent wrong result (exit 0 where
an error was due, or a missing warning). Usage: python tools/audit_round2.py WORKDIR
"""

from __future__ import annotations

import io
import json
import os
import re
import resource
import shutil
import socket
import subprocess
import sys
import threading
import time
import xml.etree.ElementTree as ET
import zipfile
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
BIN = str(Path(sys.executable).parent / "platypose")
PY = sys.executable
TAKE = REPO / "data/video/pose2sim-balancing"
CALIB = REPO / "tests/data/calib"
MEMORY_LIMIT = 3 * 2**30
BLOWUP_KB = 2 * 2**20  # 2 GB in ru_maxrss units
INTERNAL = re.compile(
    r"\b(TypeError|KeyError|AttributeError|IndexError|ZeroDivisionError|OverflowError|RecursionError|LinAlgError|"
    r"MemoryError|RuntimeError|AssertionError|UnpicklingError|NameError|UnboundLocalError)\b"
)
COUNTS = ["outside", "hang", "memory", "traceback", "internal", "silent"]


def _limit() -> None:
    resource.setrlimit(resource.RLIMIT_AS, (MEMORY_LIMIT, MEMORY_LIMIT))
    os.setsid()


def _snapshot(folder: Path, skip: Path) -> dict:
    return {
        str(p): p.stat().st_mtime_ns for p in folder.rglob("*") if p.is_file() and skip not in p.parents and p != skip
    }


class Audit:
    def __init__(self, work: Path) -> None:
        self.work = work
        self.rows: list[dict] = []

    def run(self, name: str, args: list[str], expect: str, needle: str = "", timeout: float = 240, cwd=None, out=None,
            python: bool = False) -> dict:  # fmt: skip
        """``expect``: "error" (exit 2, one line with ``needle``), "ok" (exit 0), "warn" (exit 0, ``needle`` on stderr)."""
        case = self.work / name
        case.mkdir(parents=True, exist_ok=True)
        out = Path(out) if out else case / "out"
        before = _snapshot(case, out)
        command = [PY, "-c", args[0]] if python else [BIN, *args]
        env = dict(os.environ, OMP_NUM_THREADS="1", MKL_NUM_THREADS="1")
        wrapper = [PY, "-c", (
            "import resource,subprocess,sys,json;"
            "p=subprocess.run(sys.argv[2:],capture_output=True,text=True,timeout=float(sys.argv[1]));"
            "print(json.dumps([p.returncode,p.stdout[-4000:],p.stderr[-4000:],"
            "resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss]))"
        ), str(timeout), *command]  # fmt: skip
        started = time.monotonic()
        row = {"case": name, "expect": expect, **{k: 0 for k in COUNTS}}
        try:
            done = subprocess.run(wrapper, capture_output=True, text=True, timeout=timeout + 30, cwd=cwd or case,
                                  env=env, preexec_fn=_limit)  # fmt: skip
            code, stdout, stderr, rss = json.loads(done.stdout) if done.stdout.strip() else (None, "", done.stderr, 0)
        except (subprocess.TimeoutExpired, json.JSONDecodeError):
            code, stdout, stderr, rss = None, "", "", 0
        if code is None and not stderr:
            row["hang"] = 1
        if "TimeoutExpired" in (stderr or ""):
            row["hang"], stderr = 1, ""
        row["seconds"] = round(time.monotonic() - started, 1)
        row["code"], row["rss_mb"] = code, round(rss / 1024)
        text = f"{stdout}\n{stderr}"
        if rss > BLOWUP_KB or "MemoryError" in text:
            row["memory"] = 1
        if "Traceback (most recent call last)" in text:
            row["traceback"] = 1
        summaries = [p.read_text() for p in out.rglob("summary.json")] if out.is_dir() else []
        if INTERNAL.search(text + "".join(summaries)):
            row["internal"] = 1
        after = _snapshot(case, out)
        row["outside"] = int(any(p not in before or before[p] != t for p, t in after.items()))
        lines = [line for line in (stderr or "").strip().splitlines() if line.strip()]
        if not row["hang"]:
            if expect == "error" and not (code == 2 and lines and needle in stderr):
                row["silent"] = int(code == 0)
                row["note"] = f"exit {code}: {(lines or [''])[-1][:160]}"
            elif expect == "ok" and code != 0:
                row["note"] = f"exit {code}: {(lines or [''])[-1][:160]}"
            elif expect == "warn" and not (code == 0 and needle in text):
                row["silent"] = int(code == 0)
                row["note"] = f"exit {code}, no warning {needle!r}"
        self.rows.append(row)
        flags = [k for k in COUNTS if row[k]]
        print(f"{name:38s} exit {code!s:4s} {row['seconds']:6.1f} s {row['rss_mb']:5d} MB {' '.join(flags)} "
              f"{row.get('note', '')}", flush=True)  # fmt: skip
        return row


def _npz_with(path: Path, **members: bytes | np.ndarray) -> Path:
    with zipfile.ZipFile(path, "w") as z:
        for key, value in members.items():
            if not isinstance(value, bytes):
                buffer = io.BytesIO()
                np.lib.format.write_array(buffer, value, allow_pickle=True)
                value = buffer.getvalue()
            z.writestr(f"{key}.npy", value)
    return path


def _rewrite(source: Path, path: Path, **changes) -> Path:
    with zipfile.ZipFile(source) as a, zipfile.ZipFile(path, "w") as out:
        for info in a.infolist():
            key = info.filename[:-4]
            if key in changes:
                value = changes[key]
                if not isinstance(value, bytes):
                    buffer = io.BytesIO()
                    np.lib.format.write_array(buffer, value)
                    value = buffer.getvalue()
                out.writestr(info.filename, value)
            else:
                out.writestr(info.filename, a.read(info))
    return path


class _Reduce:
    def __init__(self, func, *args, state=None):
        self.func, self.args, self.state = func, args, state

    def __reduce__(self):
        return (self.func, self.args) if self.state is None else (self.func, self.args, self.state)


def _server(reply: bytes) -> int:
    listener = socket.create_server(("127.0.0.1", 0))

    def serve():
        while True:
            conn, _ = listener.accept()
            try:
                conn.recv(64)
                conn.sendall(reply)
            finally:
                conn.close()

    threading.Thread(target=serve, daemon=True).start()
    return listener.getsockname()[1]


def main(work: Path) -> None:
    shutil.rmtree(work, ignore_errors=True)
    work.mkdir(parents=True)
    a = Audit(work)
    fixtures = work / "fixtures"
    fixtures.mkdir()
    good = fixtures / "good.mp4"
    subprocess.run([PY, "-c", (
        "import sys; from pathlib import Path; sys.path.insert(0, 'tests'); import conftest, numpy as np;"
        "from platypose.detectors.video import iter_frames;"
        f"frames=[f[::2, ::2].copy() for _, f in iter_frames(Path('{TAKE}/cam01.mp4'), max_frames=12)];"
        f"conftest._write_clip(Path('{good}'), frames, 60.0)"
    )], cwd=REPO, check=True)  # fmt: skip
    lift = ["--samples", "2", "--quiet", "--threads", "1"]

    # 1. job names inside --out
    names = work / "names" / "in"
    names.mkdir(parents=True)
    for n in ("...mp4", "..mp4", ".hidden.mp4", "summary.json.mp4", "a\nerror: forged.mp4", "x" * 240 + ".mp4"):
        shutil.copy(good, names / n)
    a.run("names/batch", ["lift", str(names), "--out", str(work / "names/out"), "--formats", "npz,bvh", *lift], "ok",
          out=work / "names/out")  # fmt: skip
    forged = work / "names/out"
    listing = sorted(p.name for p in forged.iterdir()) if forged.is_dir() else []
    print("   out folder:", listing)

    # 2. calibration bounds
    first = (CALIB / "caliscope/camera_array.toml").read_text().split("\n\n")[0]
    big = work / "calib" / "many.toml"
    big.parent.mkdir()
    big.write_text("\n\n".join(first.replace("[cameras.0]", f"[cameras.{i}]").replace("cam_id =0", f"cam_id ={i}")
                               for i in range(20000)))  # fmt: skip
    a.run("calib/caliscope-20000", ["calib", "check", str(big)], "error", "20000 cameras")
    big300 = work / "calib" / "c300.toml"
    big300.write_text("\n\n".join(first.replace("[cameras.0]", f"[cameras.{i}]").replace("cam_id =0", f"cam_id ={i}")
                                  for i in range(300)))  # fmt: skip
    a.run("calib/caliscope-300", ["calib", "check", str(big300)], "error", "300 cameras")
    huge = work / "calib" / "huge.toml"
    huge.write_bytes((CALIB / "caliscope/camera_array.toml").read_bytes() + b"#" * (20 * 2**20))
    a.run("calib/20MiB", ["calib", "check", str(huge)], "error", "too large")
    deep_json = work / "calib" / "deep.json"
    deep_json.write_text("[" * 100_000 + "]" * 100_000)
    a.run("calib/deep-json", ["calib", "check", str(deep_json)], "error", "not valid JSON")
    deep_toml = work / "calib" / "deep.toml"
    deep_toml.write_text("a = " + "[" * 100_000 + "]" * 100_000)
    a.run("calib/deep-toml", ["calib", "check", str(deep_toml)], "error", "not valid TOML")
    deep_obj = work / "calib" / "deep-obj.json"
    deep_obj.write_text('{"a":' * 50_000 + "1" + "}" * 50_000)
    a.run("calib/deep-json-objects", ["calib", "check", str(deep_obj)], "error", "not valid JSON")

    # 10. importers
    def vicon(name, **attrs):
        tree = ET.parse(CALIB / "vicon/opencap_testCalibration.xcp")
        cam = next(c for c in tree.getroot().findall("Camera") if "VIDEO" in c.attrib.get("TYPE", "").upper())
        key = cam.find("KeyFrames/KeyFrame")
        for k, v in attrs.items():
            (cam if k in cam.attrib else key).set(k, v)
        path = work / "calib" / f"{name}.xcp"
        tree.write(path)
        return path

    for name, attrs, needle in (
        ("vicon-focal-1e-300", {"FOCAL_LENGTH": "1e-300"}, "focal length"),
        ("vicon-focal-1e300", {"FOCAL_LENGTH": "1e300"}, "focal length"),
        ("vicon-focal-nan", {"FOCAL_LENGTH": "nan"}, "non-finite"),
        ("vicon-sensor-1e200", {"SENSOR_SIZE": "1e200 1e200"}, "pixel counts"),
        ("vicon-sensor-0", {"SENSOR_SIZE": "0 0"}, "pixel counts"),
        ("vicon-radial-1e10", {"VICON_RADIAL2": "Vicon3Parameter 960 540 1e10 1e10 1e10"}, "distortion"),
        ("vicon-radial-neg", {"VICON_RADIAL2": "Vicon3Parameter 960 540 -1e-3 0 0"}, "distortion"),
        ("vicon-position-1e300", {"POSITION": "1e300 0 0"}, "error:"),
        ("vicon-quat-zero", {"ORIENTATION": "0 0 0 0"}, "quaternion"),
    ):
        a.run(f"calib/{name}", ["calib", "check", str(vicon(name, **attrs))], "error", needle)
    qualisys = (CALIB / "pose2sim_demo.qca.txt").read_text()
    for name, pattern, repl, needle in (
        ("qualisys-focal-1e308", r'focalLengthU="[^"]*"', 'focalLengthU="1e308"', "focal length"),
        ("qualisys-focal-0", r'focalLengthU="[^"]*"', 'focalLengthU="0"', "focal length"),
        ("qualisys-dist-1e9", r'radialDistortion1="[^"]*"', 'radialDistortion1="1e9"', "distortion"),
    ):
        path = work / "calib" / f"{name}.qca.txt"
        path.write_text(re.sub(pattern, repl, qualisys))
        a.run(f"calib/{name}", ["calib", "check", str(path)], "error", needle)
    for scale, name in ((1e-3, "qualisys-metres"), (0.0, "qualisys-one-point")):
        tree = ET.parse(CALIB / "pose2sim_demo.qca.txt")
        for t in tree.getroot().iter("transform"):
            for axis in "xyz":
                t.set(axis, repr(float(t.get(axis)) * scale))
        path = work / "calib" / f"{name}.qca.txt"
        tree.write(path)
        a.run(f"calib/{name}", ["calib", "check", str(path)], "error", "within")
    freemocap = (CALIB / "freemocap_test_data_camera_calibration.toml").read_text()
    for name, pattern, repl, needle in (
        ("freemocap-one-point", r"translation = \[[^\]]*\]", "translation = [ 0.0, 0.0, 0.0,]", "within"),
        ("freemocap-dist-1e9", r"distortions = \[[^\]]*\]", "distortions = [ 1e9, 0.0, 0.0, 0.0, 0.0,]", "distortion"),
        ("freemocap-bigint", r"translation = \[[^\]]*\]", "translation = [ " + "9" * 400 + ", 0.0, 0.0,]", "error:"),
    ):
        path = work / "calib" / f"{name}.toml"
        path.write_text(re.sub(pattern, repl, freemocap, count=0 if "one-point" in name else 1))
        a.run(f"calib/{name}", ["calib", "check", str(path)], "error", needle)
    for real in ("vicon/opencap_testCalibration.xcp", "pose2sim_demo.qca.txt", "freemocap_test_data_camera_calibration.toml",
                 "caliscope/camera_array.toml", "anipose_mm.toml"):  # fmt: skip
        a.run(f"calib/real-{Path(real).name}", ["calib", "check", str(CALIB / real)], "ok")
    a.run("calib/real-h36m_cameras.json", ["calib", "check", str(CALIB / "h36m_cameras.json")], "error", "--subject")

    # 3. pickle bombs (the motion reader)
    bombs = work / "pickle"
    bombs.mkdir()
    doubled: list = []
    for _ in range(40):
        doubled = [doubled, doubled]
    wide: list = [0.0] * 3
    for _ in range(24):
        wide = [wide, wide]
    reconstruct = np.zeros(1).__reduce__()[0]
    payloads = {
        "deep40": doubled,
        "wide24": wide,
        "ndarray-2e40": _Reduce(np.ndarray, (2**40,)),
        "reconstruct-2e40": _Reduce(reconstruct, np.ndarray, (2**40,), b"b"),
        "setstate-2e40": _Reduce(reconstruct, np.ndarray, (0,), b"b", state=(1, (2**40,), np.dtype("f8"), False, b"")),
        "dtype-huge": _Reduce(np.ndarray, (4,), np.dtype(("V", 2**30))),
        "dict-deep": None,
    }
    nested: dict = {}
    for _ in range(5000):
        nested = {"a": nested}
    payloads["dict-deep"] = nested
    for name, clip in payloads.items():
        path = bombs / f"{name}_data_3d_h36m.npz"
        try:
            np.savez(path, positions_3d=np.array({"S1": {"Walking": clip}}, dtype=object))
        except RecursionError:
            continue
        a.run(f"pickle/{name}", ["motion", "info", str(path)], "error", "positions_3d")

    # 4. Ray
    ssh = _server(b"SSH-2.0-OpenSSH_9.6\r\n")
    with socket.create_server(("127.0.0.1", 0)) as probe:
        closed = probe.getsockname()[1]
    for name, address, needle in (
        ("closed-port", f"127.0.0.1:{closed}", "nothing answers"),
        ("nonsense", "nonsense", "not an address"),
        ("ray-client-closed", f"ray://127.0.0.1:{closed}", "nothing answers"),
        ("ssh-server", f"127.0.0.1:{ssh}", "not as a Ray cluster"),
        ("unresolvable", "no-such-host.invalid:6379", "nothing answers"),
        ("port-0", "127.0.0.1:0", "not an address"),
    ):
        a.run(f"ray/{name}", ["lift", str(good), "--out", str(work / f"ray/{name}/out"), "--executor", "ray",
                             "--ray-address", address, *lift], "error", needle, timeout=90)  # fmt: skip

    # 5 and 7. resume
    res = work / "resume"
    base = ["lift", str(good), "--out", str(res / "out"), "--formats", "npz,bvh", *lift]
    a.run("resume/first", base, "ok", out=res / "out")
    bvh = res / "out/good/good_p0.bvh"
    text = bvh.read_text()
    bvh.write_text(text[:-2] + ("1" if text[-2] != "1" else "2") + text[-1])
    (res / "out/.good.999999999.x.partial").mkdir()
    row = a.run("resume/changed-output", [*base, "--resume"], "ok", out=res / "out")
    summary = json.loads((res / "out/summary.json").read_text())
    if summary["counts"]["skipped"]:
        row["silent"] = 1
        print("   silent: a changed output was skipped")
    if list((res / "out").glob(".good.*.partial")):
        row["silent"] = 1
        print("   stale staging folder left")
    a.run("resume/runtime", [*base, "--resume", "--runtime", "float32"], "ok", out=res / "out")
    summary = json.loads((res / "out/summary.json").read_text())
    if summary["counts"]["skipped"]:
        a.rows[-1]["silent"] = 1
        print("   silent: another runtime was skipped")
    kp = res / "kp"
    shutil.copytree(TAKE / "openpose-body25b/cam01_json", kp / "cam01_json")
    kbase = ["lift", "--keypoints", str(kp / "cam01_json"), "--fps", "60", "--image-size", "1088x1920", "--out",
             str(res / "kout"), "--formats", "npz", *lift]  # fmt: skip
    a.run("resume/keypoints-first", kbase, "ok", out=res / "kout")
    files = sorted((kp / "cam01_json").iterdir())
    shutil.copy2(files[-1], files[len(files) // 2])
    a.run("resume/keypoints-cp-p", [*kbase, "--resume"], "ok", out=res / "kout")
    if json.loads((res / "kout/summary.json").read_text())["counts"]["skipped"]:
        a.rows[-1]["silent"] = 1
        print("   silent: keypoints copied with an old time were skipped")

    # 6. priors
    pri = work / "prior"
    pri.mkdir()
    teacher = pri / "teacher.pt"
    shutil.copy(REPO / "lifting/priors/default.pt", teacher)
    before = teacher.read_bytes()
    a.run("prior/distil-into-teacher", ["train", str(REPO / "data/motion/deepmimic"), "--out", str(teacher),
                                       "--distil-from", str(teacher), "--iterations", "1"], "error", "teacher")  # fmt: skip
    if teacher.read_bytes() != before:
        a.rows[-1]["silent"] = 1
    import torch

    for name, edit, needle in (
        ("steps-1e9", lambda p: p["config"].update(diffusion_steps=1e9), "diffusion_steps"),
        ("steps-int-1e9", lambda p: p["config"].update(diffusion_steps=10**9), "diffusion_steps"),
        ("layers-1e6", lambda p: p["config"].update(layers=10**6), "layers"),
        ("width-str", lambda p: p["config"].update(width="64"), "not a valid"),
        ("fps-nan", lambda p: p["config"].update(fps=float("nan")), "fps"),
        ("sampling-steps", lambda p: p["manifest"].update(sampling_steps=[10**12]), "sampling_steps"),
        ("clips-bad", lambda p: p["manifest"].update(clips=[{"name": 1}]), "clips"),
        ("manifest-list", lambda p: p.update(manifest=[1]), "manifest"),
    ):
        payload = torch.load(REPO / "lifting/priors/default.pt", weights_only=True)
        edit(payload)
        path = pri / f"{name}.pt"
        torch.save(payload, path)
        a.run(f"prior/{name}", ["prior-info", str(path)], "error", needle)

    # 8. sync
    sy = work / "sync"
    sy.mkdir()
    check = ["calib", "check", str(TAKE / "calib_pose2sim.toml"), "--keypoints", str(TAKE / "openpose-body25b"),
             "--fps", "60", "--sync"]  # fmt: skip
    for name, text, needle in (
        ("offset-1e6", '{"cam01": 0, "cam02": 1e6, "cam03": 0, "cam04": 0}', "at most"),
        ("offset-1e4", '{"cam01": 0, "cam02": 1e4, "cam03": 0, "cam04": 0}', "shares no time"),
        ("offset-400-digits", '{"cam01": 0, "cam02": ' + "9" * 400 + ', "cam03": 0, "cam04": 0}', "finite"),
        ("offset-nan", '{"cam01": 0, "cam02": NaN, "cam03": 0, "cam04": 0}', "finite"),
        ("offset-deep", '{"cam01":' + "[" * 100000 + "]" * 100000 + "}", "not valid JSON"),
        ("offset-string", '{"cam01": "late"}', "camera name"),
    ):
        path = sy / f"{name}.json"
        path.write_text(text)
        a.run(f"sync/{name}", [*check, str(path)], "error", needle)
    broken = sy / "broken.json"
    broken.write_text("{oops")
    a.run("sync/broken-one-view", ["lift", "--keypoints", str(TAKE / "openpose-body25b/cam01_json"), "--fps", "60",
                                  "--cams", str(TAKE / "calib_pose2sim.toml"), "--sync", str(broken), "--out",
                                  str(sy / "out1"), *lift], "error", "not valid JSON")  # fmt: skip
    still = sy / "still"
    for view in sorted((TAKE / "openpose-body25b").iterdir()):
        files = sorted(view.glob("*.json"))
        (still / view.name).mkdir(parents=True)
        for i, f in enumerate(files):
            source = files[0] if view.name == "cam02_json" else f
            (still / view.name / f"{view.name[:-5]}.{i:04d}.json").write_bytes(source.read_bytes())
    a.run("sync/still-view", ["calib", "check", str(TAKE / "calib_pose2sim.toml"), "--keypoints", str(still),
                             "--fps", "60", "--sync", "auto"], "warn", "barely moves")  # fmt: skip
    short = sy / "short"
    for view in sorted((TAKE / "openpose-body25b").iterdir()):
        (short / view.name).mkdir(parents=True)
        for f in sorted(view.glob("*.json"))[:60]:
            (short / view.name / f.name).write_bytes(f.read_bytes())
    a.run("sync/one-second", ["calib", "check", str(TAKE / "calib_pose2sim.toml"), "--keypoints", str(short),
                             "--fps", "60", "--sync", "auto"], "warn", "s of frames")  # fmt: skip
    slow = sy / "fps"
    (slow).mkdir()
    subprocess.run([PY, "-c", (
        "import sys; from pathlib import Path; sys.path.insert(0, 'tests'); import conftest;"
        "from platypose.detectors.video import iter_frames;"
        f"frames=[f for _, f in iter_frames(Path('{TAKE}/cam02.mp4'), max_frames=12)];"
        f"conftest._write_clip(Path('{slow}/cam02.mp4'), frames, 30.0);"
        f"frames=[f for _, f in iter_frames(Path('{TAKE}/cam01.mp4'), max_frames=24)];"
        f"conftest._write_clip(Path('{slow}/cam01.mp4'), frames, 60.0)"
    )], cwd=REPO, check=True)  # fmt: skip
    a.run("sync/60-and-30-fps", ["lift", str(slow), "--cams", str(TAKE / "calib_pose2sim.toml"), "--out",
                                str(sy / "fpsout"), *lift], "error", "frame rates",
          out=sy / "fpsout")  # fmt: skip

    # 9. swapped cameras, names matching nothing
    sw = work / "swap"
    for src, dst in (("cam01", "cam03"), ("cam02", "cam02"), ("cam03", "cam01"), ("cam04", "cam04")):
        (sw / "kp" / f"{dst}_json").mkdir(parents=True)
        for f in sorted((TAKE / "openpose-body25b" / f"{src}_json").glob("*.json")):
            (sw / "kp" / f"{dst}_json" / f.name.replace(src, dst)).write_bytes(f.read_bytes())
    a.run("swap/cam01-cam03", ["lift", "--keypoints", str(sw / "kp"), "--cams", str(TAKE / "calib_pose2sim.toml"),
                              "--fps", "60", "--image-size", "1920x1088", "--out", str(sw / "out"), "--formats",
                              "npz", *lift], "warn", "swapped",
          out=sw / "out")  # fmt: skip
    nm = work / "names2" / "in"
    nm.mkdir(parents=True)
    for n in ("front", "side", "back", "top"):
        shutil.copy(good, nm / f"{n}.mp4")
    a.run("names/no-camera-matches", ["lift", str(nm), "--cams", str(TAKE / "calib_pose2sim.toml"), "--out",
                                     str(work / "names2/out"), *lift], "error", "name each video",
          out=work / "names2/out")  # fmt: skip

    # 12. damaged results
    dm = work / "damaged"
    dm.mkdir()
    a.run(
        "damaged/make", ["lift", str(good), "--out", str(dm / "out"), "--formats", "npz", *lift], "ok", out=dm / "out"
    )
    src = dm / "out/good/good.npz"
    with np.load(src, allow_pickle=False) as d:
        hyp, med = d["hypotheses"], d["median"]
    P, N, T = hyp.shape[:3]
    header = (
        b"\x93NUMPY\x01\x00v\x00"
        + ("{'descr': '<f4', 'fortran_order': False, 'shape': (%d, %d, %d, 17, 3), }" % (P, N, 10**9))
        .ljust(117)
        .encode()
        + b"\n"
        + b"\x00" * 64
    )
    for name, changes, needle in (
        ("inf", {"hypotheses": np.full_like(hyp, np.inf), "median": np.full_like(med, np.inf)}, "infinite"),
        ("neg-inf", {"hypotheses": np.where(np.isnan(hyp), hyp, -np.inf).astype(hyp.dtype)}, "infinite"),
        ("times-1e30", {"hypotheses": hyp * 1e30, "median": med * 1e30}, "from the origin"),
        ("times-1e4", {"hypotheses": hyp * 1e4, "median": med * 1e4}, "from the origin"),
        ("header-760GiB", {"hypotheses": header}, "GiB"),
        ("meta-deep", {"meta": np.array("[" * 100_000 + "]" * 100_000)}, "nested too deeply"),
        ("meta-bigint", {"meta": np.array('{"a": ' + "9" * 5000 + "}")}, "error:"),
    ):
        path = _rewrite(src, dm / f"{name}.npz", **changes)
        a.run(f"damaged/info-{name}", ["info", str(path)], "error", needle)
        a.run(f"damaged/export-{name}", ["export", str(path), "--formats", "bvh", "--out", str(dm / f"x-{name}")],
              "error", needle, out=dm / f"x-{name}")  # fmt: skip
    frames = dm / "5M-frames.npz"
    with zipfile.ZipFile(frames, "w", compression=zipfile.ZIP_DEFLATED) as z, zipfile.ZipFile(src) as s:
        for info in s.infolist():
            if info.filename == "hypotheses.npy":
                with z.open("hypotheses.npy", "w", force_zip64=True) as m:
                    np.lib.format.write_array_header_1_0(m, {"descr": "<f4", "fortran_order": False,
                                                             "shape": (1, 1, 5_000_000, 17, 3)})  # fmt: skip
                    chunk = np.zeros(2**22, np.float32).tobytes()
                    left = 5_000_000 * 51 * 4
                    while left > 0:
                        m.write(chunk[: min(len(chunk), left)])
                        left -= len(chunk)
            else:
                z.writestr(info.filename, s.read(info))
    a.run("damaged/info-5M-frames", ["info", str(frames)], "error", "GiB")

    # 13. smaller
    for spec in ("0,0,-1,0", "1,0,0,0", "0,0,0,0", "nan,0,1,0", "0,0,1,1e300"):
        a.run(f"floor/{spec}", ["lift", str(good), "--floor", spec, "--out", str(work / "floor/out"), *lift], "error",
              "floor")  # fmt: skip
    motion = str(REPO / "data/motion/deepmimic")
    for name, options, needle in (
        ("noise-nan", ["--noise-px", "nan"], "--noise-px"),
        ("noise-neg", ["--noise-px", "-5"], "--noise-px"),
        ("views-0", ["--views", "0"], "--views"),
        ("views-neg", ["--views", "-2"], "--views"),
        ("json-folder", ["--json", str(work)], "folder"),
    ):
        a.run(f"eval/{name}", ["eval", motion, *options], "error", needle)
    a.run("newline-in-error", ["calib", "check", "no\nerror: forged.toml"], "error", "no?error")

    totals = {k: sum(r[k] for r in a.rows) for k in COUNTS}
    failing = [r for r in a.rows if any(r[k] for k in COUNTS) or "note" in r]
    print(f"\n{len(a.rows)} cases; " + ", ".join(f"{k} {v}" for k, v in totals.items()))
    print(f"cases with a flag or a note: {len(failing)}")
    for r in failing:
        print("  ", r["case"], {k: r[k] for k in COUNTS if r[k]}, r.get("note", ""))
    (work / "audit.json").write_text(json.dumps({"totals": totals, "rows": a.rows}, indent=1))


if __name__ == "__main__":
    main(Path(sys.argv[1]))
