"""The command's hooks on the one view reader (:mod:`platypose.detectors.view_reader`): the model loaded once per
process, a progress bar per video, the parsing of ``--image-size``."""

from __future__ import annotations

import functools
import sys
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

import typer

from platypose.lifting.settings import DetectOptions


def image_size_option(value: str | None) -> tuple[int, int] | None:
    """``HEIGHTxWIDTH`` -> (height, width)."""
    from platypose.lifting.errors import InputError

    if value is None:
        return None
    height, sep, width = value.lower().partition("x")
    if not sep or not (height + width).isascii() or not height.isdigit() or not width.isdigit():
        raise InputError(f"--image-size {value}: give HEIGHTxWIDTH in pixels, e.g. 1080x1920")
    return int(height), int(width)


@functools.lru_cache(maxsize=4)
def cached_detector(options: DetectOptions):
    """The detector of ``options``, loaded once per process (a batch worker keeps it for its next inputs)."""
    from platypose.detectors.view_reader import load_model

    return load_model(options)


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
