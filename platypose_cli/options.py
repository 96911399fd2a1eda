"""Command-line options shared by several commands, built from the library's settings dataclasses.

One table per settings class names the flags of its fields (:data:`SAMPLER_FLAGS` for
:class:`~platypose.lifting.sampler_config.SamplerConfig`, :data:`WINDOW_FLAGS` for
:class:`~platypose.lifting.lift.WindowSettings`, :data:`PRIOR_FLAGS` for
:class:`~platypose.lifting.runtime.PriorSettings`). A command decorated with
``@settings_options("sampler")`` gets one typer option per row and receives the built
settings object in its ``sampler`` parameter; an option not given takes the class's
default (the one source of defaults; --help shows it), unless the command sets its own (``defaults=``).

To add an option: add the field to the dataclass (its check in ``__post_init__``, its
message naming the field, not a flag) and a row to its table here; every command using
the group has it, and tests/test_cli_options.py checks the row against the class.
"""

from __future__ import annotations

import functools
import inspect
import re
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

import typer

from platypose.lifting.errors import InputError


@dataclass(frozen=True)
class Flag:
    """A settings field (``field``, of type ``type``) as a command-line option spelled ``names`` (the first is
    documented; the others are older spellings kept as aliases)."""

    field: str
    type: object
    names: tuple[str, ...]
    help: str


SAMPLER_FLAGS = (
    Flag("samples", int, ("--samples",), "Hypotheses per person."),
    Flag("steps", int, ("--steps",), "Diffusion steps kept, of the prior's 50 (T)."),
    Flag("skip", int, ("--skip",), "Noisiest kept steps skipped (S)."),
    Flag("guidance_iters", int, ("--guidance-iters", "--k"), "Guidance steps per diffusion step, at most (k)."),
    Flag("energy_scale", float, ("--energy-scale", "--lambda"), "Initial guidance step (lambda)."),
    Flag("eta", float, ("--eta",), "DDIM eta: 0 deterministic re-noising, 1 fresh noise."),
    Flag("solver", str, ("--solver",), "Re-noising between network calls: ddim or dpm2m (DPM-Solver++(2M))."),
    Flag("temperature", float, ("--temperature",), "Scale of the initial noise (1: the prior as trained)."),
    Flag("robust", str, ("--robust",), "Reprojection loss: l2 or geman-mcclure."),
    Flag("size_prior", bool, ("--size-prior/--no-size-prior",), "Place each prediction as a person of adult size."),
    Flag("size_spread", float, ("--size-spread",), "Log-normal spread of the hypotheses' sizes (0: all typical)."),
    Flag("noise_fit", bool, ("--noise-fit/--no-noise-fit",), "Follow the 2D only as far as its jitter allows."),
    Flag("noise_spread", bool, ("--noise-spread/--no-noise-spread",), "2+ views: spread hypotheses by the 2D noise."),
    Flag("bone_weight", float, ("--bone-weight",), "Constant bone lengths over time (0: off)."),
    Flag("symmetry_weight", float, ("--symmetry-weight",), "Left/right bone symmetry (0: off)."),
    Flag(
        "depth_smoothness", float, ("--depth-smoothness",), "One view: smoothness of every joint's depth path (0: off)."
    ),
    Flag("seed", int, ("--seed",), "Random seed of the sampler."),
)
WINDOW_FLAGS = (
    Flag("window", int, ("--window",), "Window length in prior frames (capped by the prior)."),
    Flag("overlap", int, ("--overlap",), "Frames shared by consecutive windows."),
)
PRIOR_FLAGS = (
    Flag("path", Path, ("--prior",), "Motion prior checkpoint (default: the shipped one)."),
    Flag("device", str, ("--device",), "Sampler device: cpu, cuda or auto (cuda when available)."),
    Flag(
        "runtime",
        str,
        ("--runtime",),
        "Denoiser runtime: auto (bfloat16 where this CPU runs it fast, else float32), float32, bfloat16 or onnx.",
    ),
)
SETTINGS = {  # the settings class of each table, imported when a command runs (torch stays out of --help)
    "sampler": ("platypose.lifting.sampler_config", "SamplerConfig", SAMPLER_FLAGS),
    "windows": ("platypose.lifting.lift", "WindowSettings", WINDOW_FLAGS),
    "prior": ("platypose.lifting.runtime", "PriorSettings", PRIOR_FLAGS),
}
FLAG_SPELLINGS = {"detector format": "--detector-format", "person detector": "--person-detector"}


def settings_class(group: str) -> type:
    """The settings dataclass of ``group`` (a key of :data:`SETTINGS`)."""
    import importlib

    module, name, _ = SETTINGS[group]
    return getattr(importlib.import_module(module), name)


@functools.cache
def declared_defaults(group: str) -> dict[str, object]:
    """The defaults ``group``'s class declares, read from its source without importing it (the sampler's module
    imports torch, which would make ``platypose --help`` take seconds); literal defaults only."""
    import ast
    import importlib.util

    module, name, _ = SETTINGS[group]
    tree = ast.parse(Path(importlib.util.find_spec(module).origin).read_text(encoding="utf-8"))
    (body,) = [node.body for node in tree.body if isinstance(node, ast.ClassDef) and node.name == name]
    return {
        node.target.id: ast.literal_eval(node.value)
        for node in body
        if isinstance(node, ast.AnnAssign) and isinstance(node.target, ast.Name) and node.value is not None
    }


def settings_options(
    group: str,
    *,
    parameter: str | None = None,
    only: Sequence[str] | None = None,
    exclude: Sequence[str] = (),
    defaults: Mapping[str, object] | None = None,
) -> Callable[[Callable], Callable]:
    """Give a typer command one option per row of ``group``'s table (``only`` those fields, or all but
    ``exclude``) and call it with ``group=SettingsClass(**values given)``; a value the class refuses is an
    InputError. An option left out takes the class's default, or this command's ``defaults``. The command
    receives the object in ``parameter`` (default: the group's name).
    """
    _, _, flags = SETTINGS[group]
    chosen = [f for f in flags if (only is None or f.field in only) and f.field not in exclude]
    defaults = dict(defaults or {})
    label = group.replace("_", " ")
    parameter = parameter or group
    shown = declared_defaults(group)

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
                    defaults.get(f.field),
                    *f.names,
                    help=f.help,
                    show_default=f.field in defaults or _shown(shown.get(f.field), f.names),
                    rich_help_panel=label.title(),
                ),
                annotation=f.type if f.field in defaults else f.type | None,
            )
            for f in chosen
        ]
        kept = [
            p.replace(kind=inspect.Parameter.KEYWORD_ONLY, annotation=_resolved(p.annotation, command))
            for n, p in signature.parameters.items()
            if n != parameter
        ]

        @functools.wraps(command)
        def wrapper(**values):
            given = {f.field: values.pop(f.field) for f in chosen}
            try:
                built = settings_class(group)(**{k: v for k, v in given.items() if v is not None})
            except InputError:
                raise
            except ValueError as err:
                raise InputError(f"{label}: {err}") from None
            return command(**values, **{parameter: built})

        wrapper.__signature__ = signature.replace(parameters=kept + added)
        wrapper.__annotations__ = {p.name: p.annotation for p in kept + added}
        del wrapper.__wrapped__  # typer must read the new signature, not the command's
        return wrapper

    return decorate


def _shown(default: object, names: Sequence[str]) -> str | bool:
    """How --help shows a class default: the value, the flag of a true/false switch, or nothing for None."""
    if default is None:
        return False
    if isinstance(default, bool):
        on, _, off = names[0].partition("/")
        return (on if default else off).lstrip("-")
    return str(default)


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
