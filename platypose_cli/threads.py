"""The default number of threads torch and onnxruntime get per input: one, in ``lift``, ``demo`` and ``bench``.

The rule, measured (docs/results.md, "Default threads"): on the shared 2-core machine, with another CPU-bound
process running, one thread per input lifted the sports2d demo end to end many times faster than two (OpenMP
threads spin while they wait for a core that another process holds); on a quiet machine the small prior gains
little from a second thread. A machine with cores to spare runs more inputs at once instead (``--jobs``: one
process per input, one thread each), which never oversubscribes it. ``--threads`` overrides the rule.
"""

from __future__ import annotations

DEFAULT_THREADS = 1


def threads_for(given: int | None) -> int:
    """The threads an input gets: ``given`` (``--threads``), else ``DEFAULT_THREADS``."""
    return given if given is not None else DEFAULT_THREADS
