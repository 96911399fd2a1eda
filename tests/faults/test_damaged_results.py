"""Damaged result files (infinite or absurd coordinates, a header claiming gigabytes, meta nested too deeply) are
refused by ``info`` and ``export`` in one line, writing nothing; the undamaged result still reads."""

from __future__ import annotations

from pathlib import Path

import pytest


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
