"""Detection and the prior's architecture are options groups declared once, by their settings classes
(lifting/settings/): every field of DetectOptions is an option of ``detect`` and, but those a lift leaves to its
own options, of ``lift``; every option field of PriorArchitecture is an option of ``train``; a field added to either
class is an option of every command taking its group, the commands unedited."""

from __future__ import annotations

import dataclasses
import importlib
import inspect

import pytest
from typer.models import OptionInfo

import platypose.cli.commands_detect as commands_detect
import platypose.cli.commands_lift as commands_lift
import platypose.cli.commands_train as commands_train
from platypose.cli.terminal import options
from platypose.lifting.settings import DetectOptions, PriorArchitecture, setting

COMMANDS = (commands_detect, commands_lift, commands_train)


def option_names(command) -> set[str]:
    """The parameters of a command (as typer reads its signature) that are options."""
    return {name for name, p in inspect.signature(command).parameters.items() if isinstance(p.default, OptionInfo)}


def option_fields(cls: type) -> set[str]:
    return {f.name for f in dataclasses.fields(cls) if f.metadata["option"]}


def test_every_detection_field_is_an_option_of_detect_and_of_lift_but_those_it_leaves():
    fields = {f.name for f in dataclasses.fields(DetectOptions)}
    assert option_fields(DetectOptions) == fields
    assert fields <= option_names(commands_detect.detect)
    leaves = set(commands_lift.LIFT_LEAVES)
    assert leaves < fields and fields - leaves <= option_names(commands_lift.lift)
    assert not (leaves - {"threads"}) & option_names(commands_lift.lift)  # --threads is lift's own, torch's too


def test_every_architecture_option_is_an_option_of_train():
    assert option_fields(PriorArchitecture) and option_fields(PriorArchitecture) <= option_names(commands_train.train)


@pytest.fixture
def wider_classes(monkeypatch):
    """DetectOptions and PriorArchitecture each with one more option field, the commands imported again with them;
    afterwards imported again with the real classes."""
    extra = ("batch_frames", int, setting(8, "Frames per batch.", option=True))
    for group, cls in (("detect", DetectOptions), ("architecture", PriorArchitecture)):
        wider = dataclasses.make_dataclass(f"Wider{cls.__name__}", [extra], bases=(cls,), frozen=True)
        monkeypatch.setitem(options.SETTINGS, group, wider)
    options.flags.cache_clear()
    yield [importlib.reload(module) for module in COMMANDS]
    monkeypatch.undo()
    options.flags.cache_clear()
    for module in COMMANDS:
        importlib.reload(module)


def test_a_field_added_to_a_group_is_an_option_of_every_command_taking_it(wider_classes):
    detect, lift, train = wider_classes
    assert all("batch_frames" in option_names(command) for command in (detect.detect, lift.lift, train.train))
