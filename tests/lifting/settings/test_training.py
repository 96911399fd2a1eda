"""PriorArchitecture (lifting/settings/training.py): the prior's size defined once, for ``train``'s options and
:class:`PriorConfig`; the shipped prior is of that architecture."""

from __future__ import annotations

import dataclasses
import inspect

from platypose.lifting.prior.model import PriorConfig, load_prior
from platypose.lifting.settings import PriorArchitecture


def test_train_options_are_the_fields_of_the_architecture():
    from platypose.cli.commands_train import train

    options = inspect.signature(train).parameters
    for field in (f for f in dataclasses.fields(PriorArchitecture) if f.metadata["option"]):
        assert options[field.name].default.default == field.default
        assert options[field.name].default.help == field.metadata["help"]


def test_prior_config_is_the_architecture_plus_schedule_and_features():
    config = PriorConfig()
    assert dataclasses.asdict(PriorArchitecture()).items() <= dataclasses.asdict(config).items()
    assert [f.name for f in dataclasses.fields(config)][-2:] == ["diffusion_steps", "features"]
    shipped = load_prior(None)[0].config
    assert (shipped.layers, shipped.width, shipped.heads, shipped.ff_width) == (4, 256, 4, 512)
