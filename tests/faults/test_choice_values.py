"""Values a user types or passes through the API for who to lift, the floor, sync offsets and addresses: digits
are ASCII digits, counts and ids cannot be mistaken, booleans are not numbers, NumPy scalars are numbers, and a
point outside the image is refused (each an InputError naming the option and the problem)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np
import pytest

from platypose.cli.detection import image_size_option
from platypose.cli.ray_address import host_port
from platypose.detectors.persons.person_choice import parse_persons
from platypose.detectors.tracking.tracker import persons_to_keep
from platypose.detectors.types import PoseTrack2D
from platypose.lifting.calibration import load_calibration, save_calibration
from platypose.lifting.errors import InputError
from platypose.lifting.settings import TakeSettings
from platypose.pipeline import take_settings

CALIB = Path(__file__).resolve().parents[2] / "data/video/pose2sim-balancing/calib_pose2sim.toml"


@pytest.mark.parametrize("text", ["²", "³,", "@²,5", "largest:²", "id:٣", "1_0,", "@1_0,5", "@1e999,5"])
def test_persons_takes_ascii_digits_only(text: str) -> None:
    with pytest.raises(InputError, match="persons must be") as err:
        parse_persons(text)
    assert err.value.option == "persons"


def test_api_persons_superscript_is_an_input_error() -> None:
    with pytest.raises(InputError, match=r"persons must be .* got '²'"):
        take_settings(persons="²")


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


@pytest.mark.parametrize("offset", [1e308, -1e6])
def test_calibration_time_offset_is_bounded(tmp_path: Path, offset: float) -> None:
    path = tmp_path / "c.json"
    save_calibration(path, load_calibration(CALIB))
    content = json.loads(path.read_text())
    content["cameras"][1]["time_offset_s"] = offset
    path.write_text(json.dumps(content))
    expected = (
        f"c.json: camera 'cam_02' time_offset_s {offset:g} is out of range (a finite number of seconds, at most 86400"
    )
    with pytest.raises(InputError, match=re.escape(expected)):
        load_calibration(path)
