"""The one exception type for bad user input (files, arguments, calibration)."""

from __future__ import annotations


class InputError(ValueError):
    """A problem with something the user gave us; the message is one line naming the file and the problem.

    The CLI prints it without a traceback and exits with code 2. When the problem is one
    parameter's value, ``option`` holds that parameter's name as the message spells it
    (``"persons"``, ``"detector_format"``): the library never names command-line flags, and
    the CLI puts its flag in that place (:func:`platypose.cli.terminal.options.cli_message`).
    """

    def __init__(self, message: str, option: str | None = None) -> None:
        super().__init__(message)
        self.option = option
