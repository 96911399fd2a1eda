"""A split lift's pieces and ``--collect``: pieces damaged after a killed run, a ``.pieces`` that is not a folder,
an earlier run's files beside a collected one; against the real CLI, each ending in a clean error or handled well
(:mod:`audit_support`). Every case is an audit case: run with ``pytest -m audit``.

``K`` and ``SPLIT`` are the issue's: a copy of the balancing take's cam01 OpenPose folder at 20 fps, 2 hypotheses,
npz only; pieces of 2 s on two processes. ``killed SPLIT-run``: ``lift K SPLIT`` killed (SIGKILL) once two lift
pieces are in ``.pieces``."""

from __future__ import annotations

import io
import os
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest
from audit_support import Case, Run, check_case, openpose_copy, platypose, registry, summary

pytestmark = pytest.mark.audit

CASES: list[Case] = []
case = registry(CASES)

K = ["--fps", "20", "--image-size", "1920x1080", "--samples", "2", "--threads", "1", "-q", "--formats", "npz"]
SPLIT = ["--floor", "none", "--split-seconds", "2", "--max-gap", "1", "--jobs", "2"]


def lift_k(w: Path, *extra) -> list:
    keypoints = w / "kp/cam01_json"
    if not keypoints.exists():
        openpose_copy(w / "kp", frames=100)
    return ["lift", "--keypoints", keypoints, *K, *extra, "--out", w / "o/c"]


def killed_split_run(w: Path) -> list[Path]:
    """Start ``lift K SPLIT``, SIGKILL it once two lift pieces are written; those pieces."""
    command = [sys.executable, "-m", "platypose", *map(str, lift_k(w, *SPLIT))]
    process = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    pieces = w / "o/c/cam01/.pieces"
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and len(list(pieces.glob("lift.*.npz"))) < 2 and process.poll() is None:
        time.sleep(0.05)
    process.kill()
    process.wait()
    found = sorted(pieces.glob("lift.*.npz"))
    assert found, "the split run wrote no piece before it ended"
    return found


def damaged_piece_run(w: Path, damage) -> Run:
    damage(killed_split_run(w)[0])

    def check(proc) -> str | None:
        (entry,) = summary(w / "o/c")["inputs"]
        said = [line for line in entry["warnings"] if line.startswith("damaged split piece ")]
        if not said or "removed, lifted again" not in said[0]:
            return f"no warning about the damaged piece: {entry['warnings']}"
        return None if (w / "o/c/cam01/cam01.npz").is_file() else "no npz written"

    return Run(lift_k(w, *SPLIT), "ok", check, timeout=300)


@case("killed-split-run-piece-truncated-to-30000-bytes")
def _(w: Path) -> Run:
    return damaged_piece_run(w, lambda path: os.truncate(path, 30000))


def deflated_zeros(path: Path) -> None:
    """A piece replaced by about 4 MB of deflated zeros claiming 4 GB of hypotheses."""
    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(
        header, {"descr": "<f4", "fortran_order": False, "shape": (1, 2, 2 * 10**7, 51)}
    )
    with zipfile.ZipFile(path, "w", zipfile.ZIP_DEFLATED) as archive:
        with archive.open("hypotheses.npy", "w", force_zip64=True) as member:
            member.write(header.getvalue())
            for _ in range(4000):
                member.write(bytes(10**6))
        archive.writestr("energy.npy", header.getvalue())


@case("killed-split-run-piece-of-deflated-zeros")
def _(w: Path) -> Run:
    return damaged_piece_run(w, deflated_zeros)


def tampered(path: Path) -> None:
    with np.load(path) as data:
        arrays = {name: data[name] for name in data.files}
    arrays["hypotheses"] = arrays["hypotheses"] + 0.5
    with open(path, "wb") as stream:
        np.savez(stream, **arrays)


@case("killed-split-run-piece-tampered")
def _(w: Path) -> Run:
    return damaged_piece_run(w, tampered)


@case("pieces-folder-is-a-symlink-out-of-out")
def _(w: Path) -> Run:
    elsewhere = w / "elsewhere"
    elsewhere.mkdir()
    (w / "o/c/cam01").mkdir(parents=True)
    (w / "o/c/cam01/.pieces").symlink_to(elsewhere)

    def check(proc) -> str | None:
        return f"pieces written outside --out: {list(elsewhere.iterdir())}" if list(elsewhere.iterdir()) else None

    says = (".pieces: is a symbolic link, not the folder of pieces platypose made; remove it",)
    return Run(lift_k(w, *SPLIT), check=check, says=says, timeout=300)


@case("pieces-folder-is-a-regular-file")
def _(w: Path) -> Run:
    (w / "o/c/cam01").mkdir(parents=True)
    (w / "o/c/cam01/.pieces").write_text("")
    says = (".pieces: is a regular file, not the folder of pieces platypose made; remove it",)
    return Run(lift_k(w, *SPLIT), says=says, timeout=300)


@case("collect-removes-an-earlier-runs-outputs")
def _(w: Path) -> Run:
    args = lift_k(w)
    at = args.index("--formats")
    first = platypose([*args[:at], "--formats", "npz,csv,angles", *args[at + 2 :]], 240)
    assert first is not None and first.returncode == 0, first and first.stderr

    def check(proc) -> str | None:
        import json

        folder = w / "o/c/cam01"
        there = sorted(p.name for p in folder.iterdir() if p.name.startswith("cam01"))
        listed = json.loads((folder / "lift.json").read_text())["outputs"]
        return None if there == listed == ["cam01.npz"] else f"stale: files {there}, lift.json lists {listed}"

    return Run(lift_k(w, "--executor", "ray", "--collect"), "ok", check, timeout=300)


@pytest.mark.parametrize("audit_case", CASES, ids=[c.name for c in CASES])
def test_audit_case(audit_case: Case, tmp_path: Path) -> None:
    check_case(audit_case, tmp_path)
