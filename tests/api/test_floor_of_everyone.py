"""Choosing whom to lift does not move an estimated floor: it comes from everyone in the take (one chosen
person once re-estimated the camera at 2.15 m instead of 3.49 m)."""

from __future__ import annotations

import pytest

import platypose
from platypose.data import VIDEO_DIR

VIEW = VIDEO_DIR / "pose2sim-balancing/openpose-body25b/cam01_json"


@pytest.fixture
def tiny_default_prior(monkeypatch, prior_file):
    """The tiny prior in place of the shipped one."""
    from pathlib import Path

    import platypose.lifting.prior.model as prior_module

    monkeypatch.setattr(prior_module, "DEFAULT_PRIOR", Path(prior_file))
    return prior_file


def test_one_chosen_person_keeps_the_floor_of_everyone(tiny_default_prior) -> None:
    common = {"samples": 2, "steps": 2, "skip": 1, "seed": 0, "stride": 1, "fps": 60.0, "image_size": (1088, 1920)}
    everyone = platypose.lift([VIEW], persons="all", **common)
    assert len(everyone.track_ids) > 1, "the take needs several people for this test"
    assert everyone.meta["floor"] is not None and everyone.meta["floor"]["source"] == "estimated"
    smallest = int(everyone.track_ids[-1])
    chosen = platypose.lift([VIEW], persons=f"id:{smallest}", **common)
    assert chosen.track_ids.tolist() == [smallest]
    assert chosen.meta["persons"] == f"persons id:{smallest}: the tracks with these ids: p{smallest}"
    assert chosen.meta["floor"]["camera_height_m"] == pytest.approx(everyone.meta["floor"]["camera_height_m"])
    assert chosen.meta["floor"]["camera_pitch_deg"] == pytest.approx(everyone.meta["floor"]["camera_pitch_deg"])
