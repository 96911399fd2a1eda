"""The offline commands' own files (``train``, ``eval``, ``prior-info``, ``calibrate-prior``): a prior's piece
index, the pieces a rewrite removes (never a user's file beside them), motion packs and unseen-sets files, crafted or
damaged, against the real CLI; each ends in a clean error or handled well (:mod:`audit_support`). Every case is an
audit case: run with ``pytest -m audit``."""

from __future__ import annotations

import io
import json
import os
import zipfile
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pytest
from audit_support import DATA, WALK, Case, Run, check_case, edit_json, openpose_copy, registry

pytestmark = pytest.mark.audit

CASES: list[Case] = []
case = registry(CASES)

TRAIN = ["--iterations", "3", "--batch-size", "2", "--layers", "1", "--width", "16", "--heads", "1", "--ff-width", "16"]
T = [*TRAIN, "--checkpoint-every", "2", "--validate-every", "2", "--threads", "1", "--quiet"]
PACK = DATA / "motion-pack.npz"


def pieces_prior(w: Path) -> Path:
    """``pr/pp.pt``: the shipped prior written as an index and 1 MiB pieces."""
    from platypose.lifting.prior.model import DEFAULT_PRIOR, write_checkpoint_bytes

    (w / "pr").mkdir()
    write_checkpoint_bytes(w / "pr/pp.pt", DEFAULT_PRIOR.read_bytes(), 2**20)
    return w / "pr/pp.pt"


def lift_with(w: Path, prior: Path) -> list:
    """``pp lift K --prior PRIOR``: the issue's K on a copy of the balancing take's cam01 keypoints."""
    keypoints = openpose_copy(w / "kp")
    k = ["--fps", "20", "--image-size", "1920x1080", "--samples", "2", "--threads", "1", "-q", "--formats", "npz"]
    return ["lift", "--keypoints", keypoints, *k, "--prior", prior, "--out", w / "out"]


def one_piece_6000_times(w: Path) -> Path:
    path = pieces_prior(w)
    edit_json(path, lambda ix: ix.update(pieces=[ix["pieces"][0]] * 6000))
    return path


SUM = ("pp.pt", "the index's piece sizes do not sum to its 9,094,645 bytes")


@case("prior-pieces-one-piece-6000-times-prior-info")
def _(w: Path) -> Run:
    return Run(["prior-info", one_piece_6000_times(w)], says=SUM)


@case("prior-pieces-one-piece-6000-times-lift")
def _(w: Path) -> Run:
    return Run(lift_with(w, one_piece_6000_times(w)), says=SUM)


@case("prior-pieces-one-piece-6000-times-distil-from")
def _(w: Path) -> Run:
    return Run(["train", WALK, "--distil-from", one_piece_6000_times(w), "--out", w / "d.pt", *T], says=SUM)


@case("prior-piece-linked-to-a-2gb-file-elsewhere")
def _(w: Path) -> Run:
    path = pieces_prior(w)
    big = w / "big.bin"
    big.touch()
    os.truncate(big, 2**31)  # sparse: 2 GiB named, nothing written
    piece = path.parent / f"{path.name}.{json.loads(path.read_text())['sha256'][:12]}.002"
    piece.unlink()
    piece.symlink_to(big)
    return Run(["prior-info", path], says=("pp.pt: piece 2 of 9", "is a link leading out of the index's folder"))


@case("prior-piece-replaced-by-a-2gb-file")
def _(w: Path) -> Run:
    path = pieces_prior(w)
    piece = sorted(path.parent.glob("pp.pt.*.003"))[0]
    os.truncate(piece, 2**31)
    return Run(["prior-info", path], says=("pp.pt: piece 3 of 9", "has 2147483648 bytes, the index says 1048576"))


@case("prior-pieces-bytes-1e400")
def _(w: Path) -> Run:
    path = pieces_prior(w)
    path.write_text(path.read_text().replace('"bytes": 9094645', '"bytes": 1e400'))
    return Run(["prior-info", path], says=("pp.pt: damaged index of prior pieces",))


@case("prior-pieces-index-nested-100000-deep")
def _(w: Path) -> Run:
    path = pieces_prior(w)
    path.write_text('{"format": "platypose-prior-pieces", "x": ' + "[" * 100_000 + "]" * 100_000 + "}")
    return Run(["prior-info", path], says=("pp.pt: damaged index of prior pieces (nested too deep)",))


def users_file_kept(path: Path) -> Callable:
    """A check that the user's file ``path`` beside a checkpoint is still there, unchanged."""
    path.write_text("my notes")
    return lambda proc: None if path.is_file() and path.read_text() == "my notes" else f"{path.name} was removed"


@case("train-out-keeps-a-users-file-beside-it")
def _(w: Path) -> Run:
    return Run(["train", WALK, "--out", w / "prior.pt", *T], "ok", users_file_kept(w / "prior.pt.notes.001"))


@case("distil-out-keeps-a-users-file-beside-it")
def _(w: Path) -> Run:
    check = users_file_kept(w / "d.pt.0123456789ab.001")  # the writer's form, but no index of d.pt listed it
    return Run(["train", WALK, "--distil-from", pieces_prior(w), "--out", w / "d.pt", *T], "ok", check)


@case("calibrate-prior-out-keeps-a-users-file-beside-it")
def _(w: Path) -> Run:
    args = [
        "calibrate-prior",
        DATA / "motion",
        "--out",
        w / "c.pt",
        "--frames",
        "1",
        "--windows",
        "1",
        "--samples",
        "2",
    ]
    return Run([*args, "--grid", "1"], "ok", users_file_kept(w / "c.pt.notes.001"))


def pack_arrays() -> dict[str, np.ndarray]:
    with np.load(PACK, allow_pickle=False) as data:
        return {name: data[name] for name in data.files}


def pack_with(w: Path, name: str, **changes) -> Path:
    np.savez_compressed(w / name, **{**pack_arrays(), **changes})
    return w / name


def train_pack(w: Path, pack: Path) -> list:
    return ["train", pack, "--out", w / "x.pt", *T]


@case("pack-truncated-train")
def _(w: Path) -> Run:
    (w / "trunc.npz").write_bytes(PACK.read_bytes()[:2267555])
    return Run(train_pack(w, w / "trunc.npz"), says=("trunc.npz: not a readable motion pack (truncated",))


def fps_case(fps: str) -> Callable[[Path], Run]:
    """The pack with ``fps`` as its frame rate, trained on."""

    def build(w: Path) -> Run:
        pack = pack_with(w, "fps.npz", fps=np.array(float(fps)))
        return Run(train_pack(w, pack), says=("fps.npz: motion pack fps must be a number in (0, 1000]",))

    return build


for _fps in ("0", "nan", "-30"):
    case(f"pack-fps-{_fps}")(fps_case(_fps))


@case("pack-header-claims-10e10-frames")
def _(w: Path) -> Run:
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<i2", "fortran_order": False, "shape": (10**10, 17, 3)})
    pack = w / "huge.npz"
    with zipfile.ZipFile(pack, "w") as archive:
        for name, value in pack_arrays().items():
            member = io.BytesIO()
            np.lib.format.write_array(member, value)
            archive.writestr(f"{name}.npy", header.getvalue() if name == "joints_mm" else member.getvalue())
    return Run(train_pack(w, pack), says=("huge.npz: not a readable motion pack", "'joints_mm' claims 949.9 GiB"))


@case("pack-25m-frames-of-deflated-zeros")
def _(w: Path) -> Run:
    frames, chunk = 25_000_000, 2**26
    arrays = {**pack_arrays(), "lengths": np.array([frames]), "origins": np.zeros((1, 3))}
    arrays.update(
        original_fps=np.array([30.0]), names=np.array(["z"]), sources=np.array(["z"]), licences=np.array(["z"])
    )
    pack = w / "zeros.npz"
    with zipfile.ZipFile(pack, "w", zipfile.ZIP_DEFLATED) as archive:
        for name, value in arrays.items():
            if name != "joints_mm":
                member = io.BytesIO()
                np.lib.format.write_array(member, value)
                archive.writestr(f"{name}.npy", member.getvalue())
        with archive.open("joints_mm.npy", "w", force_zip64=True) as member:
            shape = {"descr": "<i2", "fortran_order": False, "shape": (frames, 17, 3)}
            np.lib.format.write_array_header_1_0(member, shape)
            left, zeros = frames * 17 * 3 * 2, bytes(chunk)
            while left > 0:
                member.write(zeros[: min(chunk, left)])
                left -= chunk
    return Run(train_pack(w, pack), says=("zeros.npz: not a readable motion pack", "'joints_mm' claims 2.4 GiB"))


@case("pack-origins-1e300")
def _(w: Path) -> Run:
    origins = pack_arrays()["origins"].copy()
    origins[0] = 1e300
    pack = pack_with(w, "far.npz", origins=origins)
    return Run(train_pack(w, pack), says=("far.npz: motion pack origin of clip 0", "not within 1000 m"))


def sets_file(w: Path, text: str) -> Path:
    (w / "deepmimic").symlink_to(DATA / "motion/deepmimic")
    (w / "unseen.json").write_text(text)
    return w / "unseen.json"


def fifo_sets(w: Path) -> Path:
    os.mkfifo(w / "unseen.json")
    return w / "unseen.json"


FIFO = ("unseen.json: is a FIFO (named pipe), a regular unseen-sets file was expected",)
EVAL = ["--frames", "1", "--samples", "2", "--windows", "1", "--views", "1", "--no-baseline"]


@case("sets-fifo-eval")
def _(w: Path) -> Run:
    return Run(["eval", "--sets", fifo_sets(w), *EVAL], timeout=60, says=FIFO)


@case("sets-fifo-train-hold-out")
def _(w: Path) -> Run:
    return Run(["train", WALK, "--hold-out", fifo_sets(w), "--out", w / "x.pt", *T], timeout=60, says=FIFO)


@case("sets-absolute-pattern-eval")
def _(w: Path) -> Run:
    spec = sets_file(w, '{"a": ["/etc/*"]}')
    return Run(["eval", "--sets", spec, *EVAL], says=("unseen.json: set 'a': pattern '/etc/*' is absolute",))


@case("sets-empty-pattern-train-hold-out")
def _(w: Path) -> Run:
    spec = sets_file(w, '{"walks": ["deepmimic/humanoid3d_walk.txt", ""]}')
    args = ["train", DATA / "motion/deepmimic", "--hold-out", spec, "--out", w / "x.pt", *T]
    return Run(args, says=("unseen.json: set 'walks': pattern '' is empty",))


@case("sets-nested-100000-deep-eval")
def _(w: Path) -> Run:
    spec = sets_file(w, '{"a": ' + "[" * 100_000 + "]" * 100_000 + "}")
    return Run(["eval", "--sets", spec, *EVAL], says=("unseen.json: not a readable JSON file of unseen sets (nested",))


@pytest.mark.parametrize("audit_case", CASES, ids=[c.name for c in CASES])
def test_audit_case(audit_case: Case, tmp_path: Path) -> None:
    check_case(audit_case, tmp_path)
