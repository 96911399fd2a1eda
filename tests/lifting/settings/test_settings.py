"""The settings (lifting/settings/): every field has its help, defaults build, and every refusal names its field."""

from __future__ import annotations

import dataclasses
import subprocess
import sys
import typing

import pytest

from platypose.lifting.errors import InputError
from platypose.lifting.settings import (
    DistilConfig,
    PriorSettings,
    SamplerConfig,
    TakeSettings,
    TrainConfig,
    WindowSettings,
)

CLASSES = (SamplerConfig, WindowSettings, PriorSettings, TakeSettings, TrainConfig, DistilConfig)
WRONG = {int: 2.5, float: "1", bool: 1, str: ["x"]}  # a value of another type for each declared type


@pytest.mark.parametrize("cls", CLASSES, ids=lambda c: c.__name__)
def test_every_field_has_help_and_the_defaults_build(cls):
    assert all(f.metadata.get("help") for f in dataclasses.fields(cls))
    assert cls() == cls()


def fields_of_simple_type():
    for cls in CLASSES:
        hints = typing.get_type_hints(cls)
        for f in dataclasses.fields(cls):
            if hints[f.name] in WRONG:
                yield pytest.param(cls, f.name, WRONG[hints[f.name]], id=f"{cls.__name__}.{f.name}")


@pytest.mark.parametrize("cls, name, value", list(fields_of_simple_type()))
def test_a_value_of_the_wrong_type_is_refused_naming_the_field(cls, name, value):
    with pytest.raises(InputError) as caught:
        cls(**{name: value})
    assert caught.value.option == name and name in str(caught.value)


@pytest.mark.parametrize(
    "cls, values, name",
    [
        (SamplerConfig, {"samples": 0}, "samples"),
        (SamplerConfig, {"skip": 10}, "skip"),
        (SamplerConfig, {"eta": float("inf")}, "eta"),
        (SamplerConfig, {"solver": "dpm2m", "eta": 0.5}, "eta"),
        (SamplerConfig, {"floor": (0, 0, 1)}, "floor"),
        (WindowSettings, {"window": 8, "overlap": 5}, "overlap"),
        (PriorSettings, {"device": "tpu"}, "device"),
        (TrainConfig, {"learning_rate": 2.0}, "learning_rate"),
        (TrainConfig, {"time_scale": (1.2, 0.8)}, "time_scale"),
        (DistilConfig, {"calls": 0}, "calls"),
        (TakeSettings, {"root": "float"}, "root"),
        (TakeSettings, {"persons": -2}, "persons"),
    ],
)
def test_a_value_out_of_range_is_refused_naming_the_field(cls, values, name):
    with pytest.raises(InputError) as caught:
        cls(**values)
    assert caught.value.option == name


def test_numbers_are_stored_as_their_declared_type():
    import numpy as np

    config = SamplerConfig(samples=np.int64(7), eta=0, floor=[0, 0, 1, 0])
    assert type(config.samples) is int and type(config.eta) is float and config.floor == (0.0, 0.0, 1.0, 0.0)
    assert str(PriorSettings(path="p.pt").path) == "p.pt"


def test_the_module_loads_no_torch_or_numpy():
    code = "import sys, platypose.lifting.settings; print(sorted({'torch', 'numpy'} & set(sys.modules)))"
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, timeout=60)
    assert done.stdout.strip() == "[]", done.stderr


@pytest.mark.parametrize(
    "bad",
    [
        dict(samples=0),
        dict(robust="cauchy"),
        dict(skip=10),
        dict(energy_scale=-1.0),
        dict(step_rule="adam"),
        dict(decay=1.5),
        dict(depth_smoothness=-1.0),
        dict(solver="heun"),
        dict(solver="dpm2m", eta=0.5),
        dict(temperature=0.0),
        dict(temperature=2.5),
    ],
)
def test_bad_sampler_settings_are_refused(bad):
    with pytest.raises(ValueError):
        SamplerConfig(**bad)
