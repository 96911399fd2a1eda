"""Checks on what a prior checkpoint states, before anything is built from it.

A checkpoint's config decides how much memory and work loading and sampling take (``diffusion_steps = 1e9`` is a
schedule of a billion steps), and its manifest is printed and used by ``prior-info``, ``eval`` and the sampler.
Each value must have its type and lie within bounds generous for any network we train; else one line naming the
file and the field.
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Any

from platypose.lifting.errors import InputError

# field -> (type, smallest, largest); larger networks than these are not ours to load
CONFIG_BOUNDS: dict[str, tuple[type, float, float]] = {
    "layers": (int, 1, 64),
    "width": (int, 2, 4096),
    "heads": (int, 1, 64),
    "ff_width": (int, 1, 16384),
    "dropout": (float, 0.0, 1.0),
    "max_frames": (int, 1, 4096),
    "fps": (float, 1e-3, 1000.0),
    "diffusion_steps": (int, 1, 10000),
    "features": (int, 1, 4096),
}


def check_config_type(name: str, value: Any) -> None:
    """ValueError unless ``value`` is a number of the type of config field ``name`` (a whole one for int fields)."""
    kind = CONFIG_BOUNDS[name][0]
    number = isinstance(value, (int, float)) and not isinstance(value, bool)
    if not number or (kind is int and not isinstance(value, int)):
        raise ValueError(f"{name} must be {'a whole number' if kind is int else 'a number'}, got {value!r}")


def check_config_value(name: str, value: Any) -> None:
    """ValueError unless ``value`` has the type of config field ``name`` and lies within its bounds."""
    kind, low, high = CONFIG_BOUNDS[name]
    check_config_type(name, value)
    if not math.isfinite(value):
        raise ValueError(f"{name} must be {'a whole number' if kind is int else 'a number'}, got {value!r}")
    if not low <= value <= high:
        raise ValueError(f"{name} must be within [{low:g}, {high:g}], got {value!r}")


def check_config(config: Any) -> dict:
    """A checkpoint's config table, each field known and of its type within its bounds; ValueError otherwise."""
    if not isinstance(config, dict):
        raise ValueError("config is not a table")
    unknown = sorted(str(k) for k in config if k not in CONFIG_BOUNDS)
    if unknown:
        raise ValueError(f"unknown config field(s) {', '.join(unknown)}")
    for name, value in config.items():
        check_config_value(name, value)
    return config


MAX_PARAMETERS = 2**28  # weights of a prior (1 GiB in float32); the shipped one has a few million


def check_joint_names(names: Any, expected: list[str]) -> None:
    """ValueError unless ``names`` is the list of joint names ``expected`` (the prior's skeleton)."""
    if not _list_of(names, str):
        raise ValueError(f"joint_names must be a list of joint names, got {type(names).__name__}")
    if list(names) != expected:
        raise ValueError("the prior was trained on another joint set")


def check_weights(expected: dict[str, tuple[int, ...]], state: Any) -> None:
    """ValueError unless the network ``expected`` (weight name -> shape, from the config) has at most
    ``MAX_PARAMETERS`` weights and ``state`` (the checkpoint's weights) holds exactly those names and shapes:
    checked before the network is built, so a config asking for a huge network costs nothing."""
    total = sum(math.prod(shape) for shape in expected.values())
    if total > MAX_PARAMETERS:
        raise ValueError(f"the config asks for {total:,} weights, over the {MAX_PARAMETERS:,} a prior may have")
    if not isinstance(state, dict):
        raise ValueError("state_dict is not a table of weights")
    missing = sorted(set(expected) - set(state))
    unknown = sorted(str(k) for k in set(state) - set(expected))
    if missing or unknown:
        raise ValueError(f"the weights do not match the config (missing {missing[:3]}, unexpected {unknown[:3]})")
    for name, shape in expected.items():
        found = tuple(getattr(state[name], "shape", ()))
        if found != shape:
            raise ValueError(f"weights {name!r} have shape {found}, the config asks for {shape}")


def _list_of(value: Any, kind: type) -> bool:
    return isinstance(value, list) and all(isinstance(v, kind) and not isinstance(v, bool) for v in value)


def check_manifest(path: Path, manifest: Any, diffusion_steps: int) -> dict:
    """The checkpoint's manifest, checked where it is used: sampling steps (whole, within the schedule, noisiest
    first), the distillation record, licences and clips; InputError naming the field otherwise."""
    if not isinstance(manifest, dict):
        raise InputError(f"{path}: prior manifest is not a table")
    steps = manifest.get("sampling_steps")
    if steps is not None and not (
        _list_of(steps, int)
        and 0 < len(steps) <= diffusion_steps
        and all(0 <= s < diffusion_steps for s in steps)
        and all(a > b for a, b in zip(steps, steps[1:]))
    ):
        raise InputError(
            f"{path}: prior manifest sampling_steps must be decreasing steps within [0, {diffusion_steps})"
        )
    distilled = manifest.get("distilled")
    if distilled is not None and not (
        isinstance(distilled, dict)
        and isinstance(distilled.get("teacher_sha256"), str)
        and _list_of(distilled.get("teacher_steps"), int)
        and isinstance(distilled.get("iterations"), int)
        and steps is not None
    ):
        raise InputError(f"{path}: prior manifest 'distilled' is damaged")
    temperature = manifest.get("temperature")
    if temperature is not None:
        fitted = temperature.get("by_frames") if isinstance(temperature, dict) else None
        if not (
            isinstance(fitted, dict)
            and fitted
            and all(str(k).isdigit() and int(k) >= 1 for k in fitted)
            and all(isinstance(v, float) and 0.05 <= v <= 4 for v in fitted.values())
        ):
            raise InputError(
                f"{path}: prior manifest 'temperature' must give a temperature in [0.05, 4] per window length"
            )
    if not _list_of(manifest.get("licences", []), str):
        raise InputError(f"{path}: prior manifest 'licences' must be a list of names")
    clips = manifest.get("clips", [])
    fields = {"split": str, "frames": int, "licence": str, "name": str}
    if not isinstance(clips, list) or not all(
        isinstance(c, dict) and all(isinstance(c.get(k), t) for k, t in fields.items()) for c in clips
    ):
        raise InputError(f"{path}: prior manifest 'clips' must list split, frames, licence and name per clip")
    return manifest
