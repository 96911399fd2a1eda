"""Human3.6M motion files are pickles: a small file whose objects would take 2**40 elements or bytes when built
(doubled lists, huge shapes through every way numpy rebuilds an array) is refused naming the file and the key;
real data still loads, and nothing in such a file runs. The audit cases (marker ``audit``) give such files to
``motion info`` (:mod:`audit_watch`), and a file whose pickle would run code to ``motion info``, ``train`` and
``eval`` (:mod:`audit_support`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from audit_support import Case, Run, check_case, malicious_h36m, registry
from audit_watch import check

from platypose.lifting.errors import InputError


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


@pytest.mark.audit
@pytest.mark.parametrize("name", list(_bombs()))
def test_pickle_bombs_in_mocap(tmp_path: Path, name: str) -> None:
    path = tmp_path / f"{name}_data_3d_h36m.npz"
    try:
        np.savez(path, positions_3d=np.array({"S1": {"Walking": _bombs()[name]}}, dtype=object))
    except RecursionError:
        pytest.skip("numpy cannot write this one")
    check(tmp_path / "case", ["motion", "info", path], "error", (path.name, "positions_3d"))


CASES: list[Case] = []
case = registry(CASES)


@case("h36m-malicious-motion-info")
def _(w: Path) -> Run:
    data, marker = malicious_h36m(w)
    return Run(
        ["motion", "info", data],
        marker=marker,
        says=("data_3d_h36m.npz: 'positions_3d' holds more than bounded numpy arrays", "refused to load io.open"),
    )


@case("h36m-malicious-train-folder-scan")
def _(w: Path) -> Run:
    data, marker = malicious_h36m(w)
    args = ["train", data.parent, "--out", w / "p.pt", "--iterations", "1"]
    return Run(
        args,
        marker=marker,
        says=("data_3d_h36m.npz: 'positions_3d' holds more than bounded numpy arrays", "refused to load io.open"),
    )


@case("h36m-malicious-eval")
def _(w: Path) -> Run:
    data, marker = malicious_h36m(w)
    return Run(
        ["eval", data, "--frames", "1", "--samples", "2"],
        marker=marker,
        says=("data_3d_h36m.npz: 'positions_3d' holds more than bounded numpy arrays", "refused to load io.open"),
    )


@pytest.mark.audit
@pytest.mark.parametrize("audit_case", CASES, ids=[c.name for c in CASES])
def test_audit_case(audit_case: Case, tmp_path: Path) -> None:
    check_case(audit_case, tmp_path)
