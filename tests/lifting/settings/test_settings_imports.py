"""Settings are read in pure Python: importing them and making a take's settings (persons, a floor plane, a sync
choice), each choice checked, loads none of numpy, torch or cv2, so a command checks its options before anything
heavy is imported."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from platypose.lifting.errors import InputError
from platypose.lifting.settings import TakeSettings
from platypose.lifting.settings.choices import GivenPlane, read_floor

HEAVY = ("numpy", "torch", "cv2")
PROBE = f"""
import json, sys
from platypose.lifting.settings import TakeSettings
take = TakeSettings(persons="@10,20.5", floor=(0.0, 0.1, 1.0, -0.5), sync="auto", root="solve")
print(json.dumps({{"loaded": [m for m in {HEAVY!r} if m in sys.modules], "choice": repr(take.floor_choice)}}))
"""


def test_take_settings_load_no_numpy_torch_or_cv2():
    out = subprocess.run([sys.executable, "-c", PROBE], capture_output=True, text=True, check=True).stdout
    found = json.loads(out.strip().splitlines()[-1])
    assert found["loaded"] == [], found
    assert found["choice"] == "GivenPlane(nx=0.0, ny=0.1, nz=1.0, d=-0.5)"


def test_the_floor_is_read_as_the_user_gave_it_and_made_a_floor_where_it_takes_effect():
    from platypose.lifting.floor import CALIBRATED_FLOOR, FloorToEstimate, floor_for_lift

    assert read_floor("z=2") == GivenPlane(0.0, 0.0, 1.0, -2.0)
    assert TakeSettings(floor=None).floor_choice is None and TakeSettings().floor_choice == "auto"
    given = floor_for_lift(TakeSettings(floor="0,0,2,-1").floor_choice, None)
    assert given.normal == (0.0, 0.0, 1.0) and given.offset == -0.5 and given.source == "given"
    assert floor_for_lift("auto", None) == FloorToEstimate()
    assert floor_for_lift("auto", {"assumptions": []}) is CALIBRATED_FLOOR
    with pytest.raises(InputError, match="a floor's normal points up"):
        TakeSettings(floor="1,0,0.5,0")
    with pytest.raises(InputError, match="offsets file not found"):
        TakeSettings(sync="no-such-offsets.json")


def test_take_settings_check_the_persons_choice():
    assert TakeSettings(persons=2).persons == "largest:2"
    for bad in ("1", "largest:0", "@1,inf", "everyone"):
        with pytest.raises(InputError, match="persons") as err:
            TakeSettings(persons=bad)
        assert err.value.option == "persons"
