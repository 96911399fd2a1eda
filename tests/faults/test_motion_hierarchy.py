"""An ASF hierarchy must be a tree under the root: a cycle, a bone listed as its own child, or children listed
again are refused in one pass over the links (they looped for ever or grew memory by gigabytes); the audit case (marker ``audit``) runs ``motion info`` on a cycle
(:mod:`audit_support`)."""

from __future__ import annotations

import re
import shutil
import time
from pathlib import Path

import pytest
from audit_support import Case, Run, check_case

from platypose.lifting.errors import InputError
from platypose.lifting.motion_io import load_motion

ASF = Path(__file__).resolve().parents[2] / "data/motion/cmu-asf-amc/test.asf"


def edited_take(folder: Path, change) -> Path:
    """The CMU test take with its ASF hierarchy changed by ``change(text)``; returns the AMC."""
    (folder / "test.asf").write_text(change(ASF.read_text()))
    shutil.copy(ASF.with_suffix(".amc"), folder / "test.amc")
    return folder / "test.amc"


@pytest.mark.parametrize(
    "change, words",
    [
        (
            lambda t: t.replace("    ltibia lfoot\n", "    ltibia lfoot lfemur\n"),
            "bone 'lfemur' twice (under 'lhipjoint' and 'ltibia')",
        ),
        (lambda t: t.replace("    ltibia lfoot\n", "    ltibia lfoot ltibia\n"), "bone 'ltibia' as its own child"),
        (
            lambda t: t.replace("    lfoot ltoes\n", "    lfoot ltoes ltoes\n"),
            "bone 'ltoes' twice (under 'lfoot' and 'lfoot')",
        ),
        (lambda t: t.replace("    lfoot ltoes\n", "    lfoot ltoes\n    lfoot ltoes\n"), "bone 'ltoes' twice"),
    ],
)
def test_a_hierarchy_that_is_not_a_tree_is_refused(tmp_path: Path, change, words: str) -> None:
    amc = edited_take(tmp_path, change)
    started = time.perf_counter()
    with pytest.raises(InputError, match=re.escape(words)) as err:
        load_motion(amc)
    assert "InputError" not in str(err.value) and str(err.value).startswith(f"{amc.parent / 'test.asf'}: hierarchy")
    assert time.perf_counter() - started < 5


def test_every_child_listed_four_times_is_refused_at_once(tmp_path: Path) -> None:
    """7.7 kB listing every child four times reached 3.7 GB walking the repeated subtrees."""

    def fourfold(text: str) -> str:
        head, rest = text.split(":hierarchy", 1)
        body, tail = rest.split("  end", 1)
        lines = [line.split() for line in body.strip().splitlines()[1:]]
        body = "".join(f"    {line[0]} {' '.join(line[1:] * 4)}\n" for line in lines)
        return f"{head}:hierarchy\n  begin\n{body}  end{tail}"

    with pytest.raises(InputError, match=r"test.asf: hierarchy lists bone 'lhipjoint' twice .*not a tree"):
        load_motion(edited_take(tmp_path, fourfold))


def test_the_real_hierarchy_loads(tmp_path: Path) -> None:
    assert load_motion(edited_take(tmp_path, lambda t: t))[0].joints.shape[1:] == (17, 3)


def _cycle_in_motion_info(w: Path) -> Run:
    (w / "test.asf").write_text(ASF.read_text().replace("    ltibia lfoot\n", "    ltibia lfoot lfemur\n"))
    (w / "test.amc").write_bytes(ASF.with_suffix(".amc").read_bytes())
    return Run(["motion", "info", w / "test.amc"], says=("hierarchy lists bone 'lfemur' twice",), timeout=60)


@pytest.mark.audit
def test_a_cycle_in_motion_info_of_the_cli_is_a_clean_error(tmp_path: Path) -> None:
    check_case(Case("asf-cycle", _cycle_in_motion_info), tmp_path)
