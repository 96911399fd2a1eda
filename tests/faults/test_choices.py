"""Values a user types or passes through the API for who to lift, the floor, sync offsets, addresses and sampler
numbers: digits are ASCII digits, counts and ids cannot be mistaken, booleans are not numbers, NumPy scalars are
numbers, and a point outside the image is refused (each an InputError naming the option and the problem). The audit
cases (marker ``audit``, run with ``pytest -m audit``) type them into the real CLI; each must end in a clean error
checked for its words, and ``lift --help-all`` shows every option's default as it is (:mod:`audit_support`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from audit_support import Case, Run, check_case, lift_args, openpose_copy, registry

from platypose.cli.runs.ray_address import host_port
from platypose.cli.terminal.options import image_size_option
from platypose.detectors.tracking.tracker import persons_to_keep
from platypose.detectors.types import PoseTrack2D
from platypose.lifting.errors import InputError
from platypose.lifting.settings import TakeSettings
from platypose.lifting.settings.choices import parse_persons


@pytest.mark.parametrize("text", ["²", "³,", "@²,5", "largest:²", "id:٣", "1_0,", "@1_0,5", "@1e999,5"])
def test_persons_takes_ascii_digits_only(text: str) -> None:
    with pytest.raises(InputError, match="persons must be") as err:
        parse_persons(text)
    assert err.value.option == "persons"


def test_api_persons_superscript_is_an_input_error() -> None:
    with pytest.raises(InputError, match=r"persons must be .* got '²'"):
        TakeSettings(persons="²")


@pytest.mark.parametrize("text", ["²", "99999", "٣"])
def test_ray_port_takes_ascii_digits_only(text: str) -> None:
    with pytest.raises(InputError, match=f"--ray-address 127.0.0.1:{text}: not an address"):
        host_port(f"127.0.0.1:{text}")


def test_image_size_takes_ascii_digits_only() -> None:
    with pytest.raises(InputError, match="--image-size ²x³: give HEIGHTxWIDTH"):
        image_size_option("²x³")


def test_plain_number_is_refused_naming_both_meanings() -> None:
    with pytest.raises(InputError, match=r"persons 1: a plain number is ambiguous; write largest:1 .* or id:1 .*p1"):
        parse_persons("1")


def test_counts_and_ids_are_unmistakable() -> None:
    assert parse_persons("largest") == ("count", 1)
    assert parse_persons("largest:3") == ("count", 3)
    assert parse_persons("id:1") == ("ids", [1])
    assert parse_persons("id:2,0") == ("ids", [0, 2])
    assert parse_persons("1,") == ("ids", [1])  # the earlier spelling of one id still works
    assert TakeSettings(persons=2).persons == "largest:2"  # the API's int stays a count, as docs/api.md says
    with pytest.raises(InputError, match="persons must be"):
        parse_persons("largest:0")


def test_the_rule_that_picked_is_said() -> None:
    from platypose.detectors.persons.person_choice import describe_choice

    assert describe_choice("largest:2", [3, 0]) == (
        "persons largest:2: the 2 largest by size summed over frames and views: p3, p0"
    )
    assert describe_choice("id:1", [1]) == "persons id:1: the tracks with these ids: p1"


def _two_people() -> PoseTrack2D:
    keypoints = np.zeros((3, 2, 17, 3))
    keypoints[..., 2] = 1.0
    keypoints[:, 0, :, :2] = np.linspace(100, 200, 17)[:, None]
    keypoints[:, 1, :, :2] = np.linspace(500, 700, 17)[:, None]
    return PoseTrack2D(keypoints, np.arange(3) / 30, np.array([4, 7]), (720, 1280), "test")


@pytest.mark.parametrize("point", ["@-50000,-50000", "@1281,10", "@10,721"])
def test_a_point_outside_the_image_is_refused(point: str) -> None:
    with pytest.raises(InputError, match=rf"persons {point}: the point is outside the first view's image \(1280x720"):
        persons_to_keep([_two_people()], point)


def test_a_point_inside_the_image_picks_the_nearest() -> None:
    assert persons_to_keep([_two_people()], "@600,600").tolist() == [1]
    assert persons_to_keep([_two_people()], "largest").tolist() == [1]
    assert persons_to_keep([_two_people()], "id:4").tolist() == [0]


def test_floor_of_booleans_is_refused() -> None:
    with pytest.raises(InputError, match=r"floor .*\(False, False, True, False\)") as err:
        TakeSettings(floor=(False, False, True, False))
    assert err.value.option == "floor"
    assert TakeSettings(floor=(0, 0, 1.0, np.float32(0))).floor == "0.0,0.0,1.0,0.0"


def test_sync_offsets_take_numpy_scalars() -> None:
    from platypose.lifting.sync.choice import offsets_by_name

    offsets = {"cam01": np.float32(0), "cam02": np.float64(0.25), "cam03": np.int64(1)}
    assert offsets_by_name(offsets, ["cam01", "cam02", "cam03"], "sync") == [0.0, 0.25, 1.0]
    with pytest.raises(InputError, match="expected a JSON object of camera name -> offset in seconds"):
        offsets_by_name({"cam01": True}, ["cam01"], "sync")


CASES: list[Case] = []
case = registry(CASES)


@case("persons-superscript")
def _(w: Path) -> Run:
    return Run(lift_args(openpose_copy(w), w / "out", "--persons", "²"), says=("--persons", "got '²'"))


@case("ray-port-superscript")
def _(w: Path) -> Run:
    args = lift_args(openpose_copy(w), w / "out", "--executor", "ray", "--ray-address", "127.0.0.1:²")
    return Run(args, says=("--ray-address 127.0.0.1:²: not an address",))


@case("persons-point-outside-the-image")
def _(w: Path) -> Run:
    args = lift_args(openpose_copy(w), w / "out", "--persons", "@-50000,-50000")
    return Run(args, says=("@-50000,-50000: the point is outside the first view's image (1088x1920 pixels",))


@case("persons-plain-number-is-ambiguous")
def _(w: Path) -> Run:
    args = lift_args(openpose_copy(w), w / "out", "--persons", "1")
    return Run(args, says=("a plain number is ambiguous; write largest:1", "id:1"))


@case("temperature-just-over-its-bound-says-both-as-they-are")
def _(w: Path) -> Run:
    args = lift_args(openpose_copy(w), w / "out", "--temperature", "1000000.5")
    return Run(args, says=("--temperature", "must be between -1,000,000 and 1,000,000, got 1000000.5"))


@case("split-with-a-max-gap-of-1e308")
def _(w: Path) -> Run:
    args = lift_args(openpose_copy(w), w / "out", "--max-gap", "1e308", "--split-seconds", "2", "--jobs", "2")
    return Run(args, says=("--max-gap", "from 0 to 86400 (a day), got 1e+308"))


@case("energy-scale-1e308")
def _(w: Path) -> Run:
    args = lift_args(openpose_copy(w), w / "out", "--energy-scale", "1e308")
    return Run(args, says=("energy-scale", "must be between -1,000,000 and 1,000,000, got 1e+308"))


@case("lift-help-keeps-bracketed-defaults")
def _(w: Path) -> Run:
    def check(proc) -> str | None:
        shown = " ".join(proc.stdout.split())
        missing = [b for b in ("[default: 50]", "[default: l2]", "[default: out]") if b not in shown]
        if "[default: (" in shown:  # a settings option's default shown as a description (issue 52, item 12)
            return "--help shows a default in parentheses"
        return f"--help lost {missing}" if missing else None

    return Run(["lift", "--help-all"], "ok", check)  # every option: --help shows the common ones


@pytest.mark.audit
@pytest.mark.parametrize("audit_case", CASES, ids=[c.name for c in CASES])
def test_audit_case(audit_case: Case, tmp_path: Path) -> None:
    check_case(audit_case, tmp_path)
