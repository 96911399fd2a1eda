"""``eval`` prints a table or refuses: no empty table with exit 0, no floor at 1e300; a --floor that does not face up
is refused. The audit cases (marker ``audit``) give bad floors to ``lift`` and bad options to ``eval``
(:mod:`audit_watch`)."""

from __future__ import annotations

import os
from pathlib import Path

import pytest
from audit_support import WALK, platypose
from audit_watch import LIFT, REPO, check

from platypose.lifting.errors import InputError
from platypose.lifting.floor import parse_floor


@pytest.mark.parametrize("text", ["z=1e300", "z=-1e300", "z=1001"])
def test_a_floor_height_is_bounded_as_a_plane_is(text) -> None:
    with pytest.raises(InputError, match="lies within 1000 m of the origin"):
        parse_floor(text)


@pytest.mark.audit
@pytest.mark.parametrize(
    ("args", "message"),
    [
        (
            ["--frames", "64"],
            "error: --frames 64: longer than every clip (the longest has 39 frames at the prior's 30 fps)",
        ),
        (["--frames", "1", "--windows", "0"], "error: --windows 0: cut at least 1 window from each clip"),
        (["--frames", "1", "--floor", "z=1e300"], "lies within 1000 m of the origin"),
    ],
)
def test_eval_refuses_what_would_print_an_empty_or_meaningless_table(args, message) -> None:
    done = platypose(["eval", WALK, "--samples", "2", "--no-baseline", *args], 240)
    assert done is not None and done.returncode == 2, done and done.stdout
    assert "method" not in done.stdout  # no table header printed before the refusal
    lines = done.stderr.strip().splitlines()
    assert len(lines) == 1 and message in lines[0], done.stderr


def test_a_floor_plane_must_face_up() -> None:
    for spec in ("0,0,-1,0", "1,0,0,0", "0,0,1,1e9"):
        with pytest.raises(InputError, match="normal points up"):
            parse_floor(spec)
    assert parse_floor("0,0.1,1,0").normal[2] > 0.99  # a slightly tilted floor is fine


def test_bad_eval_options_are_one_line(run_cli, data_dir, tmp_path) -> None:
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


UP = "a --floor's normal points up (within 45 degrees of +z"


NON_ZERO = "the normal must be finite and non-zero"


@pytest.mark.audit
@pytest.mark.parametrize(
    ("spec", "needle"),
    [("0,0,-1,0", UP), ("1,0,0,0", UP), ("0,0,0,0", NON_ZERO), ("nan,0,1,0", NON_ZERO), ("0,0,1,1e300", UP)],
    ids=["0,0,-1,0", "1,0,0,0", "0,0,0,0", "nan,0,1,0", "0,0,1,1e300"],
)
def test_bad_floors(batch_folder, tmp_path: Path, spec: str, needle: str) -> None:
    args = ["lift", batch_folder / "good.mp4", "--floor", spec, *LIFT]
    check(tmp_path / "case", args, "error", (f"floor '{spec}'", needle))


@pytest.mark.audit
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
