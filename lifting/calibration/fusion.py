"""One quantity from several sources that measure it: the inverse-variance mean of those that agree.

Each source is an :class:`Estimate` (value, standard deviation, source), given in order of trust. A source more
than ``MAX_SIGMA`` standard deviations off the inverse-variance mean of the others (the two spreads combined) is
dropped, the farthest first, and the rest are compared again; two that disagree cannot say which of them is
wrong, so the less trusted goes. What is dropped is kept with the reason, for the log and ``meta["camera"]``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

MAX_SIGMA = 3.0


@dataclass(frozen=True)
class Estimate:
    """One source's value of a quantity, its standard deviation (> 0) and the source's name."""

    value: float
    sd: float
    source: str

    def as_dict(self) -> dict:
        """``{"value", "sd", "source"}`` for meta."""
        return {"value": float(self.value), "sd": float(self.sd), "source": self.source}


@dataclass(frozen=True)
class Fused:
    """The inverse-variance mean (``value``, ``sd``) of the ``used`` estimates; ``dropped``: each estimate left
    out and why (how many standard deviations off the others)."""

    value: float
    sd: float
    used: tuple[Estimate, ...]
    dropped: tuple[tuple[Estimate, str], ...] = ()

    @property
    def source(self) -> str:
        """The used sources' names, joined (one name where one source was used)."""
        return " + ".join(e.source for e in self.used)


def mean_of(estimates: Sequence[Estimate]) -> tuple[float, float]:
    """The inverse-variance mean and its standard deviation of ``estimates`` (at least one)."""
    weights = np.array([1.0 / e.sd**2 for e in estimates])
    values = np.array([e.value for e in estimates])
    return float(weights @ values / weights.sum()), float(1.0 / np.sqrt(weights.sum()))


def sigmas_off(estimates: Sequence[Estimate]) -> np.ndarray:
    """How many standard deviations (N,) each of ``estimates`` (two or more) is off the inverse-variance mean of
    the others, the two spreads combined."""
    off = []
    for i, one in enumerate(estimates):
        value, sd = mean_of([e for j, e in enumerate(estimates) if j != i])
        off.append(abs(one.value - value) / np.hypot(one.sd, sd))
    return np.array(off)


def fuse(estimates: Sequence[Estimate], unit: str = "") -> Fused:
    """The inverse-variance mean of ``estimates`` (in order of trust, at least one, each sd > 0), dropping while
    one is more than ``MAX_SIGMA`` off the others: the farthest, of equals the least trusted. ``unit`` follows
    the values in the reasons given."""
    if not estimates:
        raise ValueError("fuse needs at least one estimate")
    if any(not e.sd > 0 for e in estimates):
        raise ValueError(f"every estimate needs a positive sd: {[e.sd for e in estimates]}")
    kept = list(estimates)
    dropped: list[tuple[Estimate, str]] = []
    while len(kept) >= 2:
        off = sigmas_off(kept)
        worst = max(range(len(kept)), key=lambda i: (round(float(off[i]), 9), i))
        if off[worst] <= MAX_SIGMA:
            break
        others = kept[:worst] + kept[worst + 1 :]
        value, sd = mean_of(others)
        names = " + ".join(e.source for e in others)
        dropped.append((kept[worst], f"{off[worst]:.1f} sigma off {names} ({value:.1f} +- {sd:.1f}{unit})"))
        kept = others
    value, sd = mean_of(kept)
    return Fused(value, sd, tuple(kept), tuple(dropped))
