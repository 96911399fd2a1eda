"""The typer application: one sub-command module each, wired here."""

from __future__ import annotations

import os
import sys

import typer

from platypose import __version__
from platypose.cli.safe_names import printable
from platypose.lifting.errors import InputError

app = typer.Typer(
    name="platypose",
    help="Calibrated multi-hypothesis 3D human motion from videos.",
    no_args_is_help=True,
    pretty_exceptions_enable=False,
    add_completion=False,
)


def _plain_switches() -> None:
    """Show a switch in ``--help`` without a type: typer labels every option with one, ``--resume <bool>``."""
    from typer.core import TyperOption

    typed = TyperOption.display_type_rich

    def display_type_rich(self, ctx):
        return None if self.is_flag else typed(self, ctx)

    TyperOption.display_type_rich = display_type_rich


_plain_switches()


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
    import platypose.cli.commands_bench
    import platypose.cli.commands_calib
    import platypose.cli.commands_demo
    import platypose.cli.commands_detect
    import platypose.cli.commands_eval
    import platypose.cli.commands_export
    import platypose.cli.commands_info
    import platypose.cli.commands_lift
    import platypose.cli.commands_motion
    import platypose.cli.commands_train  # noqa: F401


def quiet_native_logs() -> None:
    """Keep ffmpeg's and OpenCV's own log lines off the console (platypose reports unreadable or truncated videos
    itself); a value the user set in the environment wins."""
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET
    os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")


def main() -> None:
    """Console entry point: user errors and unreadable or unwritable files become one line on stderr, exit code 2."""
    quiet_native_logs()
    _register()
    try:
        app()
    except InputError as err:
        from platypose.cli.options import cli_message

        typer.echo(printable(f"error: {cli_message(err)}"), err=True)
        sys.exit(2)
    except OSError as err:  # a file that cannot be read or written: full disk, read-only folder, name too long
        typer.echo(printable(f"error: {describe_os_error(err)}"), err=True)
        sys.exit(2)


def describe_os_error(err: OSError) -> str:
    """One line for an OSError: the file(s) it names and the system's reason."""
    names = [str(n) for n in (err.filename, err.filename2) if n is not None]
    reason = err.strerror or str(err)
    return f"{' -> '.join(names)}: {reason}" if names else reason
