"""The one exception type for bad user input (files, arguments, calibration)."""


class InputError(ValueError):
    """A problem with something the user gave us; the message is one line naming the file and the problem.

    The CLI prints it without a traceback and exits with code 2.
    """
