"""``eval`` prints a table or refuses (issue 40, "Also"): no empty table with exit 0, no floor at 1e300."""

from __future__ import annotations

import pytest
from audit_support import WALK, platypose

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
