"""Issue 17.11: every command's --help keeps its bracketed defaults ("[10]", "[on]", "[l2]"): no markup eats them."""

from __future__ import annotations

import re

import pytest
import typer.main

from platypose.cli.app import _register, app


def _commands():
    _register()
    root = typer.main.get_command(app)
    stack = [((), root)]
    while stack:
        path, command = stack.pop()
        if hasattr(command, "commands"):
            stack += [((*path, name), sub) for name, sub in command.commands.items()]
        else:
            yield path, command


@pytest.mark.parametrize("path, command", list(_commands()), ids=lambda v: " ".join(v) if isinstance(v, tuple) else "")
def test_bracketed_help_survives(run_cli, path, command):
    code, out, err = run_cli(*path, "--help")
    assert code == 0, err
    shown = " ".join(out.split())
    for param in command.params:
        for bracket in re.findall(r"\[[^\]]*\]", getattr(param, "help", None) or ""):
            assert " ".join(bracket.split()) in shown, f"{' '.join(path)} {param.name}: {bracket} lost from --help"


def test_lift_help_shows_the_sampler_defaults(run_cli):
    _, out, _ = run_cli("lift", "--help")
    shown = " ".join(out.split())
    assert "[sampler default: 50]" in shown and "[l2]" in shown and "[on]" in shown
