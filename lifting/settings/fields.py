"""The field of a settings class, with its help beside it, and the checks every settings class makes.

A field made with :func:`setting` carries its help; ``option=True`` makes it a command-line option of every
command using its class (``platypose.cli.terminal.options`` builds the flags from these fields, ``--`` and the field name
with dashes, plus the ``also`` spellings). Every check raises
:class:`~platypose.lifting.errors.InputError` with ``option`` set to the field's name, and the message names
the field as it is spelled here (the CLI puts the flag in its place). Values are checked by their declared
type first: a Python ``int`` where an integer is asked, any real number where a float is (stored as
``float``), ``True``/``False`` for switches, a path (``str`` or ``Path``) where a path is.
"""

from __future__ import annotations

import dataclasses
import functools
import math
import numbers
import os
import typing
from pathlib import Path

from platypose.lifting.errors import InputError


def setting(
    default,
    help: str,
    *,
    option: bool = False,
    also: tuple[str, ...] = (),
    panel: str | None = None,
    short: str | None = None,
    minimum: int | None = None,
    finite: bool = True,
):
    """A dataclass field with its ``help``; ``option``: a command-line option (spelled ``--field-name`` and
    ``also`` older spellings), shown in the help panel ``panel`` (default: its class's). ``short``: the help where
    a command lists the option among many (``lift``); ``minimum``: the smallest integer the field takes (checked
    by :func:`check_types`, and the option's range on the command line); ``finite=False``: a float field whose upper
    bound, infinity included, is checked later by the code that can name what it belongs to."""
    meta = {"help": help, "option": option, "also": also, "panel": panel, "short": short, "minimum": minimum}
    meta["finite"] = finite
    return dataclasses.field(default=default, metadata=meta)


def option_fields(cls: type) -> list[dataclasses.Field]:
    """The fields of settings class ``cls`` that are command-line options."""
    return [f for f in dataclasses.fields(cls) if f.metadata.get("option")]


@functools.cache
def _hints(cls: type) -> dict[str, object]:
    return typing.get_type_hints(cls)


def _checked(name: str, value: object, hint: object, minimum: int | None = None, finite: bool = True) -> object:
    """``value`` as field ``name`` of type ``hint`` stores it (an integer at least ``minimum``, if given; a float
    finite unless ``finite`` is False, NaN refused either way); InputError naming the field otherwise."""
    args = typing.get_args(hint)
    if type(None) in args:
        if value is None:
            return None
        (hint,) = [a for a in args if a is not type(None)]
        args = typing.get_args(hint)
    if hint is bool:
        ok = isinstance(value, bool)
        want = "True or False"
    elif hint is int:
        ok = isinstance(value, numbers.Integral) and not isinstance(value, bool)
        ok = ok and (minimum is None or value >= minimum)
        value, want = (int(value) if ok else value), "an integer" if minimum is None else f"an integer >= {minimum}"
    elif hint is float:
        ok = isinstance(value, numbers.Real) and not isinstance(value, bool) and not math.isnan(value)
        ok = ok and (math.isfinite(value) or not finite)
        value, want = (float(value) if ok else value), "a finite number" if finite else "a number"
    elif hint is str:
        ok, want = isinstance(value, str), "a string"
    elif hint is Path:
        ok, want = isinstance(value, (str, os.PathLike)), "a path"
        value = Path(value) if ok else value
    elif typing.get_origin(hint) is tuple:
        want = f"{len(args)} numbers"
        ok = isinstance(value, (tuple, list)) and len(value) == len(args)
        items = [_checked(name, v, a if a is int else float) for v, a in zip(value, args)] if ok else []
        value = tuple(items) if ok else value
    else:
        return value
    if not ok:
        raise InputError(f"{name} must be {want}, got {value!r}", option=name)
    return value


def check_types(settings: object) -> None:
    """Check every field of the dataclass ``settings`` against its declared type, storing the normalised value."""
    hints = _hints(type(settings))
    for f in dataclasses.fields(settings):
        metadata = f.metadata
        value = _checked(
            f.name, getattr(settings, f.name), hints[f.name], metadata.get("minimum"), metadata.get("finite", True)
        )
        object.__setattr__(settings, f.name, value)


def require(checks: list[tuple[bool, str, str]]) -> None:
    """Raise InputError(message, option=field) for the first ``(ok, field, message)`` that is not ok."""
    for ok, name, message in checks:
        if not ok:
            raise InputError(message, option=name)


def choose(name: str, value: str, choices: tuple[str, ...]) -> str:
    """The message refusing ``value`` of field ``name``, listing the ``choices``."""
    return f"unknown {name} {value!r}; choose {', '.join(choices)}"


def at_least_one(settings: object, names: tuple[str, ...]) -> list[tuple[bool, str, str]]:
    """The checks (for :func:`require`) that each field of ``names`` of ``settings`` is at least 1."""
    return [(getattr(settings, n) >= 1, n, f"{n} must be at least 1, got {getattr(settings, n)}") for n in names]
