"""Command-line options shared by several commands, built from the fields of the library's settings classes.

Every field of a settings class in :mod:`platypose.lifting.settings` made with ``setting(..., option=True)``
is an option: ``--field-name`` (a switch ``--name/--no-name``), plus its ``also`` spellings, with the
field's help (its ``short`` help where a command asks for it) and its ``minimum`` as the option's range. A command
decorated with ``@settings_options("sampler")`` gets one typer option per such field of :data:`SETTINGS`'s class
and receives the built settings object in its ``sampler`` parameter; an option not given takes the class's default
(the one source of defaults; --help shows it), unless the command sets its own (``defaults=``). The groups:
the sampler, the windows, the prior to load, detection (``detect``: ``lift`` and ``detect``), the prior's
architecture (``architecture``: ``train``), training and distillation.

To add an option: add the field to the class with ``option=True`` (its check in ``__post_init__``, its
message naming the field, not a flag); every command using the group has it.
"""

from __future__ import annotations

import functools
import inspect
import re
import typing
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from types import EllipsisType

import typer

from platypose.lifting import settings as library
from platypose.lifting.errors import InputError

SETTINGS = {  # each group of options and its settings class
    "sampler": library.SamplerConfig,
    "windows": library.WindowSettings,
    "prior": library.PriorSettings,
    "train": library.TrainConfig,
    "distil": library.DistilConfig,
    "detect": library.DetectOptions,
    "architecture": library.PriorArchitecture,
}
PANELS = {"windows": "Sampler", "prior": "Sampler"}  # groups shown in another group's help panel
RENAMED = {("prior", "path"): "--prior"}  # fields whose flag is not their name
CONTEXT = "settings_options_context"  # the typer.Context parameter settings_options adds: which options were given
FLAG_SPELLINGS = {"detector format": "--detector-format", "person detector": "--person-detector"}
TEXT = {("detect", "image_size"): "image_size_option"}  # fields given as text, parsed by this module's function


@dataclass(frozen=True)
class Flag:
    """A settings field (``field``, of type ``type``) as a command-line option spelled ``names`` (the first is
    documented; the others are older spellings kept as aliases), with its ``help`` (``short``: where a command lists
    it among many), ``default``, ``panel`` and ``minimum`` (None: no range)."""

    field: str
    type: object
    names: tuple[str, ...]
    help: str
    default: object
    panel: str
    short: str
    minimum: int | None


@functools.cache
def flags(group: str) -> tuple[Flag, ...]:
    """The options of ``group``'s settings class, one per field made with ``option=True``."""
    cls = SETTINGS[group]
    hints = typing.get_type_hints(cls)
    made = []
    for f in library.option_fields(cls):
        kind = next((a for a in typing.get_args(hints[f.name]) if a is not type(None)), hints[f.name])
        kind = str if (group, f.name) in TEXT else kind
        name = RENAMED.get((group, f.name), "--" + f.name.replace("_", "-"))
        names = (f"{name}/--no-{name[2:]}",) if kind is bool else (name, *(f"--{a}" for a in f.metadata["also"]))
        panel = f.metadata["panel"] or PANELS.get(group, group.title())
        meta = f.metadata
        made.append(
            Flag(f.name, kind, names, meta["help"], f.default, panel, meta["short"] or meta["help"], meta["minimum"])
        )
    return tuple(made)


def field_option(cls: type, name: str, panel: str | None = None, *, short: bool = False):
    """A typer option for field ``name`` of settings class ``cls``: ``--name`` (``--name/--no-name`` for a switch)
    with the field's default and help (its ``short`` help, where it has one, with ``short``), its ``minimum`` as the
    option's range."""
    field = cls.__dataclass_fields__[name]
    meta, flag = field.metadata, "--" + name.replace("_", "-")
    names = (f"{flag}/--no-{flag[2:]}",) if isinstance(field.default, bool) else (flag,)
    ranged = {} if meta.get("minimum") is None else {"min": meta["minimum"]}
    shown = (short and meta.get("short")) or meta["help"]
    return typer.Option(field.default, *names, help=shown, rich_help_panel=panel, **ranged)


def settings_options(
    group: str,
    *,
    parameter: str | None = None,
    only: Sequence[str] | None = None,
    exclude: Sequence[str] = (),
    defaults: Mapping[str, object] | None = None,
    given_only: bool = False,
    panel: str | None | EllipsisType = ...,
    short: bool = False,
    in_place: bool = False,
) -> Callable[[Callable], Callable]:
    """Give a typer command one option per row of ``group``'s table (``only`` those fields, or all but
    ``exclude``) and call it with ``group=SettingsClass(**values given)``; a value the class refuses is an
    InputError. An option left out takes the class's default, or this command's ``defaults``. The command
    receives the object in ``parameter`` (default: the group's name); ``given_only``: the dict of the values given
    instead (for a command that builds one of two classes from them). ``panel``: the help panel of every option
    (None: the command's own; default: the group's), ``short``: the fields' short help; ``in_place``: the options
    stand where ``parameter`` stands in the command's signature (default: after every other).
    """
    chosen = [f for f in flags(group) if (only is None or f.field in only) and f.field not in exclude]
    defaults = dict(defaults or {})
    parameter = parameter or group

    def decorate(command: Callable) -> Callable:
        signature = inspect.signature(command)
        clash = {f.field for f in chosen} & set(signature.parameters)
        if clash or parameter not in signature.parameters:
            raise TypeError(f"{command.__name__}: options {sorted(clash)} clash, or no parameter {parameter!r}")
        added = [
            inspect.Parameter(
                f.field,
                inspect.Parameter.KEYWORD_ONLY,
                default=typer.Option(
                    defaults.get(f.field, f.default),
                    *f.names,
                    help=f.short if short else f.help,
                    show_default=True,
                    rich_help_panel=f.panel if panel is ... else panel,
                    **({} if f.minimum is None else {"min": f.minimum}),
                ),
                annotation=f.type if f.field in defaults else f.type | None,
            )
            for f in chosen
        ]
        names = list(signature.parameters)
        at = names.index(parameter) if in_place else len(names)
        kept = [
            p.replace(kind=inspect.Parameter.KEYWORD_ONLY, annotation=_resolved(p.annotation, command))
            for n, p in signature.parameters.items()
            if n != parameter
        ]
        stacked = CONTEXT in signature.parameters  # a settings_options below this one added the context

        @functools.wraps(command)
        def wrapper(**values):
            context = values.get(CONTEXT) if stacked else values.pop(CONTEXT, None)  # an inner one reads it too
            given = {f.field: values.pop(f.field) for f in chosen}
            given = {k: v for k, v in given.items() if v is not None and (k in defaults or _given(context, k))}
            given = {k: globals()[TEXT[group, k]](v) if (group, k) in TEXT else v for k, v in given.items()}
            built = given if given_only else SETTINGS[group](**given)
            return command(**values, **{parameter: built})

        context = (
            [] if stacked else [inspect.Parameter(CONTEXT, inspect.Parameter.KEYWORD_ONLY, annotation=typer.Context)]
        )
        parameters = kept[:at] + added + kept[at:] + context
        wrapper.__signature__ = signature.replace(parameters=parameters)
        wrapper.__annotations__ = {p.name: p.annotation for p in parameters}
        del wrapper.__wrapped__  # typer must read the new signature, not the command's
        return wrapper

    return decorate


def _given(context: typer.Context | None, name: str) -> bool:
    """Whether option ``name`` was given on the command line (not left at its default); True without a context."""
    source = None if context is None else context.get_parameter_source(name)
    return source is None or source.name != "DEFAULT"


def _resolved(annotation, command: Callable):
    """An annotation written as a string (``from __future__ import annotations``) evaluated where ``command`` lives;
    a settings parameter another decorator fills (its class imported only for type checkers) stays a string."""
    if not isinstance(annotation, str):
        return annotation
    try:
        return eval(annotation, command.__globals__)
    except NameError:
        return annotation


def cli_message(err: InputError) -> str:
    """The error's message with the flag of its ``option`` (``persons`` -> ``--persons``) where the library named it:
    its first mention after a leading ``FILE: `` (a path may hold the same word), else its first mention."""
    message = str(err)
    if err.option is None:
        return message
    flag = FLAG_SPELLINGS.get(err.option, "--" + re.sub(r"[ _]", "-", err.option))
    word = re.compile(rf"\b{re.escape(err.option)}\b")
    head, colon, problem = message.partition(": ")  # "FILE: problem": the option is named in the problem
    if colon and word.search(problem):
        return head + colon + word.sub(flag, problem, count=1)
    return word.sub(flag, message, count=1)


def as_json(value) -> object:
    """Settings and paths as JSON values (for ``meta["arguments"]`` and fingerprints)."""
    from dataclasses import asdict, is_dataclass

    if is_dataclass(value):
        return {k: as_json(v) for k, v in asdict(value).items()}
    if isinstance(value, dict):
        return {k: as_json(v) for k, v in value.items()}
    return str(value) if isinstance(value, Path) else value


def int_list(text: str, what: str) -> list[int]:
    """Parse "1,16,64" into positive integers; InputError naming ``what`` otherwise."""
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise InputError(f"{what}: expected comma-separated integers, got {text!r}") from None
    if not values or min(values) < 1:
        raise InputError(f"{what}: expected positive integers, got {text!r}")
    return values


def image_size_option(value: str | None) -> tuple[int, int] | None:
    """``--image-size HEIGHTxWIDTH`` -> (height, width); InputError naming the option otherwise."""
    if value is None:
        return None
    height, sep, width = value.lower().partition("x")
    if not sep or not (height + width).isascii() or not height.isdigit() or not width.isdigit():
        raise InputError(f"--image-size {value}: give HEIGHTxWIDTH in pixels, e.g. 1080x1920")
    return int(height), int(width)
