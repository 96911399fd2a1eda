"""Damaged result files (infinite or absurd coordinates, a header claiming gigabytes, meta nested too deeply) are
refused by ``info`` and ``export`` in one line, writing nothing; the undamaged result still reads. The audit cases (marker ``audit``) damage a
result lifted by the real CLI with the shipped prior (:mod:`audit_watch`)."""

from __future__ import annotations

import zipfile
from pathlib import Path

import numpy as np
import pytest
from audit_watch import LIFT, check, npz_rewritten


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
        bad = npz_rewritten(result_npz, tmp_path / f"{name}.npz", **changes)
        for command in (("info", str(bad)), ("export", str(bad), "--formats", "bvh", "--out", str(tmp_path / name))):
            code, _, err = run_cli(*command)
            assert code == 2 and needle in err and len(err.strip().splitlines()) == 1, (name, command, err)
        assert not (tmp_path / name).exists() or not list((tmp_path / name).iterdir())
    code, _, err = run_cli("info", str(result_npz))  # the undamaged result still reads
    assert code == 0, err


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


@pytest.mark.audit
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


@pytest.mark.audit
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
