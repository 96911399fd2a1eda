"""The models a process loads once (the detector, the prior: a batch worker keeps them for its next inputs), and
the commands' view reader (:mod:`platypose.detectors.view_reader`) on that detector, with a progress bar per video."""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import typer

from platypose.lifting.settings import DetectOptions, PriorSettings


@functools.lru_cache(maxsize=4)
def cached_detector(options: DetectOptions):
    """The detector of ``options``, loaded once per process (a batch worker keeps it for its next inputs)."""
    from platypose.detectors.view_reader import load_model

    return load_model(options)


@functools.cache
def loaded_prior(settings: PriorSettings):
    """The prior of ``settings``, loaded once per process."""
    from platypose.lifting.prior.runtime import load_settings

    return load_settings(settings)


def command_reader(options: DetectOptions, cache_dir: Callable[[Path], Path], quiet: bool):
    """The view reader of ``lift`` and ``detect``: the process's model, detections cached in ``cache_dir(source)``
    (with ``options.cache``), a progress bar per video (hidden with ``quiet``)."""
    from platypose.detectors.view_reader import ViewReader

    @contextmanager
    def bar(source: Path, total: int) -> Iterator[Callable[[int, int], None]]:
        done = [0]
        with typer.progressbar(
            length=max(total, 1), label=f"detecting {source.name}", file=sys.stderr, hidden=quiet
        ) as shown:

            def progress(count: int, _total: int) -> None:
                shown.update(count - done[0])
                done[0] = count

            yield progress

    return ViewReader(options, cached_detector, cache_dir if options.cache else None, bar)
