"""Issue 17.11: every command's --help keeps the bracketed text of its option help ("[0: off]"): no markup eats it.

(The defaults themselves are shown by typer from the settings classes, tested in tests/test_cli_options.py.)
"""

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
