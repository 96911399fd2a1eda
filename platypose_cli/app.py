"""The typer application: the commands, plain functions of the ``commands_*`` modules, registered here."""

from __future__ import annotations

import os
import sys

import typer

from platypose import __version__
from platypose.cli.terminal.brief_help import brief_help
from platypose.cli.terminal.safe_names import printable
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


def register_commands() -> None:
    """Add every command to ``app``, in the order ``--help`` lists them (once: a second call adds nothing). Each is
    a plain function of its ``commands_*`` module (imported here only: they do not import the app), its options
    read when it runs, so ``platypose --help`` loads no torch."""
    if app.registered_commands:
        return
    from platypose.cli import (
        commands_bench,
        commands_calib,
        commands_demo,
        commands_detect,
        commands_doctor,
        commands_eval,
        commands_export,
        commands_lift,
        commands_motion,
        commands_train,
    )

    app.command("bench")(commands_bench.bench)
    app.command("demo")(commands_demo.demo)
    app.command("detect")(commands_detect.detect)
    app.command("eval")(commands_eval.evaluate_command)
    app.command("calibrate-prior")(commands_eval.calibrate_prior)
    app.command("info")(commands_export.info)
    app.command("export")(commands_export.export_command)
    app.command("doctor")(commands_doctor.doctor)
    app.command("lift", cls=brief_help(commands_lift.LIFT_SHOWN))(commands_lift.lift)
    app.command("train")(commands_train.train)
    app.command("prior-info")(commands_train.prior_info)
    app.add_typer(commands_calib.calib_app, name="calib")
    app.add_typer(commands_motion.motion_app, name="motion")


def quiet_native_logs() -> None:
    """Keep ffmpeg's and OpenCV's own log lines off the console (platypose reports unreadable or truncated videos
    itself); a value the user set in the environment wins."""
    os.environ.setdefault("OPENCV_FFMPEG_LOGLEVEL", "-8")  # AV_LOG_QUIET
    os.environ.setdefault("OPENCV_LOG_LEVEL", "ERROR")


def main() -> None:
    """Console entry point: user errors and unreadable or unwritable files become one line on stderr, exit code 2."""
    quiet_native_logs()
    register_commands()
    try:
        app()
    except InputError as err:
        from platypose.cli.terminal.options import cli_message

        typer.echo(printable(f"error: {cli_message(err)}"), err=True)
        sys.exit(2)
    except OSError as err:  # a file that cannot be read or written: full disk, read-only folder, name too long
        from platypose.cli.terminal.console import describe_os_error

        typer.echo(printable(f"error: {describe_os_error(err)}"), err=True)
        sys.exit(2)
