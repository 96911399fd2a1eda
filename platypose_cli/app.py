"""The typer application: one sub-command module each, wired here."""

from __future__ import annotations

import sys

import typer

from platypose.lifting.errors import InputError
from platypose import __version__

app = typer.Typer(
    name="platypose",
    help="Calibrated multi-hypothesis 3D human motion from videos.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)


def _version_callback(value: bool) -> None:
    if value:
        typer.echo(f"platypose {__version__}")
        raise typer.Exit()


@app.callback()
def _root(
    version: bool = typer.Option(
        False, "--version", callback=_version_callback, is_eager=True, help="Print the version and exit."
    ),
) -> None:
    """Calibrated multi-hypothesis 3D human motion from videos."""


def _register() -> None:
    """Import the sub-command modules, each of which adds its commands to ``app``."""
    # Sub-command modules register themselves on import; keep this list sorted.
    import platypose.cli.commands_bench  # noqa: F401
    import platypose.cli.commands_calib  # noqa: F401
    import platypose.cli.commands_demo  # noqa: F401
    import platypose.cli.commands_detect  # noqa: F401
    import platypose.cli.commands_eval  # noqa: F401
    import platypose.cli.commands_export  # noqa: F401
    import platypose.cli.commands_info  # noqa: F401
    import platypose.cli.commands_lift  # noqa: F401
    import platypose.cli.commands_motion  # noqa: F401
    import platypose.cli.commands_train  # noqa: F401


def main() -> None:
    """Console entry point: user errors become one line on stderr and exit code 2."""
    _register()
    try:
        app()
    except InputError as err:
        typer.echo(f"error: {err}", err=True)
        sys.exit(2)
