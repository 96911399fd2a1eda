"""The command line's shape (platypose_cli/, installed as platypose.cli): the top level holds only the app and the
commands; the runner and the terminal's parts live in packages by job. (Import circles and private names across
modules are checked for the whole package in tests/test_import_circles.py.)"""

from __future__ import annotations

from pathlib import Path

CLI = Path(__file__).resolve().parents[2] / "platypose_cli"


def test_the_top_level_holds_only_the_app_and_the_commands():
    loose = [p.name for p in CLI.glob("*.py") if p.name not in ("__init__.py", "app.py")]
    assert loose and all(name.startswith("commands_") for name in loose), loose
