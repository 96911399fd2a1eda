"""Argument parsing helpers shared by several commands."""

from __future__ import annotations

from platypose.lifting.errors import InputError


def int_list(text: str, what: str) -> list[int]:
    """Parse "1,16,64" into positive integers; InputError naming ``what`` otherwise."""
    try:
        values = [int(v) for v in text.split(",") if v.strip()]
    except ValueError:
        raise InputError(f"{what}: expected comma-separated integers, got {text!r}") from None
    if not values or min(values) < 1:
        raise InputError(f"{what}: expected positive integers, got {text!r}")
    return values


def sampler_config(**kwargs):
    """A SamplerConfig from CLI values, turning its validation errors into InputError."""
    from platypose.lifting.sampler import SamplerConfig

    try:
        return SamplerConfig(**kwargs)
    except ValueError as err:
        raise InputError(f"sampler: {err}") from None
