"""Audit, damaged files of our own kinds: pickle bombs in mocap, priors with bad settings, damaged results,
sync offsets out of range, and bad floor and eval values; each run ends as due, unflagged (:mod:`audit_watch`).
Run with ``pytest -m audit``."""

from __future__ import annotations

import shutil
import zipfile
from pathlib import Path

import numpy as np
import pytest
from audit_watch import LIFT, PRIOR, REPO, TAKE, check, npz_rewritten

pytestmark = pytest.mark.audit


class _Reduce:
    """Pickles as ``func(*args)`` (then ``__setstate__(state)``): a crafted object inside a mocap file."""

    def __init__(self, func, *args, state=None):
        self.func, self.args, self.state = func, args, state

    def __reduce__(self):
        return (self.func, self.args) if self.state is None else (self.func, self.args, self.state)


def _bombs() -> dict:
    doubled: list = []
    for _ in range(40):
        doubled = [doubled, doubled]
    wide: list = [0.0] * 3
    for _ in range(24):
        wide = [wide, wide]
    nested: dict = {}
    for _ in range(5000):
        nested = {"a": nested}
    reconstruct = np.zeros(1).__reduce__()[0]
    return {
        "deep40": doubled,
        "wide24": wide,
        "ndarray-2e40": _Reduce(np.ndarray, (2**40,)),
        "reconstruct-2e40": _Reduce(reconstruct, np.ndarray, (2**40,), b"b"),
        "setstate-2e40": _Reduce(reconstruct, np.ndarray, (0,), b"b", state=(1, (2**40,), np.dtype("f8"), False, b"")),
        "dtype-huge": _Reduce(np.ndarray, (4,), np.dtype(("V", 2**30))),
        "dict-deep": nested,
    }


@pytest.mark.parametrize("name", list(_bombs()))
def test_pickle_bombs_in_mocap(tmp_path: Path, name: str) -> None:
    path = tmp_path / f"{name}_data_3d_h36m.npz"
    try:
        np.savez(path, positions_3d=np.array({"S1": {"Walking": _bombs()[name]}}, dtype=object))
    except RecursionError:
        pytest.skip("numpy cannot write this one")
    check(tmp_path / "case", ["motion", "info", path], "error", (path.name, "positions_3d"))


def test_distilling_into_the_teacher_is_refused(tmp_path: Path) -> None:
    teacher = tmp_path / "teacher.pt"
    shutil.copy(PRIOR, teacher)
    before = teacher.read_bytes()
    args = ["train", REPO / "data/motion/deepmimic", "--out", teacher, "--distil-from", teacher, "--iterations", "1"]
    check(tmp_path / "case", args, "error", ("teacher.pt", "is the teacher given by --distil-from"))
    assert teacher.read_bytes() == before


@pytest.mark.parametrize(
    ("name", "edit", "needle"),
    [
        ("steps-1e9", lambda p: p["config"].update(diffusion_steps=1e9), "diffusion_steps"),
        ("steps-int-1e9", lambda p: p["config"].update(diffusion_steps=10**9), "diffusion_steps"),
        ("layers-1e6", lambda p: p["config"].update(layers=10**6), "layers"),
        ("width-str", lambda p: p["config"].update(width="64"), "not a valid"),
        ("fps-nan", lambda p: p["config"].update(fps=float("nan")), "fps"),
        ("sampling-steps", lambda p: p["manifest"].update(sampling_steps=[10**12]), "sampling_steps"),
        ("clips-bad", lambda p: p["manifest"].update(clips=[{"name": 1}]), "clips"),
        ("manifest-list", lambda p: p.update(manifest=[1]), "manifest"),
    ],
    ids=[
        "steps-1e9",
        "steps-int-1e9",
        "layers-1e6",
        "width-str",
        "fps-nan",
        "sampling-steps",
        "clips-bad",
        "manifest-list",
    ],
)
def test_priors_with_bad_settings(tmp_path: Path, name: str, edit, needle: str) -> None:
    import torch

    payload = torch.load(PRIOR, weights_only=True)
    edit(payload)
    torch.save(payload, tmp_path / f"{name}.pt")
    check(tmp_path / "case", ["prior-info", tmp_path / f"{name}.pt"], "error", (f"{name}.pt", needle))


SYNC_CHECK = ["calib", "check", TAKE / "calib_pose2sim.toml", "--keypoints", TAKE / "openpose-body25b", "--fps", "60"]


@pytest.mark.parametrize(
    ("name", "text", "needle"),
    [
        ("offset-1e6", '{"cam01": 0, "cam02": 1e6, "cam03": 0, "cam04": 0}', "at most"),
        ("offset-1e4", '{"cam01": 0, "cam02": 1e4, "cam03": 0, "cam04": 0}', "shares no time"),
        ("offset-400-digits", '{"cam01": 0, "cam02": ' + "9" * 400 + ', "cam03": 0, "cam04": 0}', "finite"),
        ("offset-nan", '{"cam01": 0, "cam02": NaN, "cam03": 0, "cam04": 0}', "finite"),
        ("offset-deep", '{"cam01":' + "[" * 100000 + "]" * 100000 + "}", "not valid JSON"),
        ("offset-string", '{"cam01": "late"}', "camera name"),
    ],
    ids=["1e6", "1e4", "400-digits", "nan", "deep", "string"],
)
def test_sync_offsets_out_of_range(tmp_path: Path, name: str, text: str, needle: str) -> None:
    (tmp_path / f"{name}.json").write_text(text)
    check(tmp_path / "case", [*SYNC_CHECK, "--sync", tmp_path / f"{name}.json"], "error", (f"{name}.json", needle))


@pytest.fixture(scope="module")
def result(batch_folder, tmp_path_factory) -> Path:
    """A result npz: good.mp4 (12 real frames) lifted with the shipped prior."""
    out = tmp_path_factory.mktemp("result")
    check(out / "make", ["lift", batch_folder / "good.mp4", "--out", out / "out", "--formats", "npz", *LIFT], "ok")
    return out / "out/good/good.npz"


def _damaged(result: Path) -> dict:
    with np.load(result, allow_pickle=False) as d:
        hyp, med = d["hypotheses"], d["median"]
    P, N = hyp.shape[:2]
    shape = "{'descr': '<f4', 'fortran_order': False, 'shape': (%d, %d, %d, 17, 3), }" % (P, N, 10**9)
    header = b"\x93NUMPY\x01\x00v\x00" + shape.ljust(117).encode() + b"\n" + b"\x00" * 64
    return {
        "inf": ({"hypotheses": np.full_like(hyp, np.inf), "median": np.full_like(med, np.inf)}, "infinite"),
        "neg-inf": ({"hypotheses": np.where(np.isnan(hyp), hyp, -np.inf).astype(hyp.dtype)}, "infinite"),
        "times-1e30": ({"hypotheses": hyp * 1e30, "median": med * 1e30}, "from the origin"),
        "times-1e4": ({"hypotheses": hyp * 1e4, "median": med * 1e4}, "from the origin"),
        "header-760GiB": ({"hypotheses": header}, "GiB"),
        "meta-deep": ({"meta": np.array("[" * 100_000 + "]" * 100_000)}, "nested too deeply"),
        "meta-bigint": (
            {"meta": np.array('{"a": ' + "9" * 5000 + "}")},
            "field 'meta' holds an integer of thousands of digits",
        ),
    }


@pytest.mark.parametrize(
    "name", ["inf", "neg-inf", "times-1e30", "times-1e4", "header-760GiB", "meta-deep", "meta-bigint"]
)
def test_damaged_results(result: Path, tmp_path: Path, name: str) -> None:
    changes, needle = _damaged(result)[name]
    path = npz_rewritten(result, tmp_path / f"{name}.npz", **changes)
    check(tmp_path / "info", ["info", path], "error", (path.name, needle))
    check(
        tmp_path / "export", ["export", path, "--formats", "bvh", "--out", tmp_path / "x"], "error", (path.name, needle)
    )


def test_a_result_over_the_size_limit(result: Path, tmp_path: Path) -> None:
    """8 million frames of one hypothesis (1.6 GB, over the 1.5 GiB a result may hold) are refused, not read."""
    frames = tmp_path / "8M-frames.npz"
    with zipfile.ZipFile(frames, "w", compression=zipfile.ZIP_DEFLATED) as z, zipfile.ZipFile(result) as s:
        for info in s.infolist():
            if info.filename != "hypotheses.npy":
                z.writestr(info.filename, s.read(info))
                continue
            with z.open("hypotheses.npy", "w", force_zip64=True) as m:
                header = {"descr": "<f4", "fortran_order": False, "shape": (1, 1, 8_000_000, 17, 3)}
                np.lib.format.write_array_header_1_0(m, header)
                chunk = np.zeros(2**22, np.float32).tobytes()
                left = 8_000_000 * 51 * 4
                while left > 0:
                    m.write(chunk[: min(len(chunk), left)])
                    left -= len(chunk)
    check(tmp_path / "case", ["info", frames], "error", ("8M-frames.npz", "GiB"))


UP = "a --floor's normal points up (within 45 degrees of +z"
NON_ZERO = "the normal must be finite and non-zero"


@pytest.mark.parametrize(
    ("spec", "needle"),
    [("0,0,-1,0", UP), ("1,0,0,0", UP), ("0,0,0,0", NON_ZERO), ("nan,0,1,0", NON_ZERO), ("0,0,1,1e300", UP)],
    ids=["0,0,-1,0", "1,0,0,0", "0,0,0,0", "nan,0,1,0", "0,0,1,1e300"],
)
def test_bad_floors(batch_folder, tmp_path: Path, spec: str, needle: str) -> None:
    args = ["lift", batch_folder / "good.mp4", "--floor", spec, *LIFT]
    check(tmp_path / "case", args, "error", (f"floor '{spec}'", needle))


@pytest.mark.parametrize(
    ("options", "needle"),
    [
        (["--noise-px", "nan"], ("--noise-px nan", "must be a finite number of pixels, 0 or more")),
        (["--noise-px", "-5"], ("--noise-px -5", "must be a finite number of pixels, 0 or more")),
        (["--views", "0"], ("--views 0", "use at least 1 camera")),
        (["--views", "-2"], ("--views -2", "use at least 1 camera")),
        (["--json", "."], ("error: .: is a folder", "an output file name was expected")),
    ],
    ids=["noise-nan", "noise-neg", "views-0", "views-neg", "json-folder"],
)
def test_bad_eval_options(tmp_path: Path, options: list, needle: tuple) -> None:
    check(tmp_path / "case", ["eval", REPO / "data/motion/deepmimic", *options], "error", needle)
