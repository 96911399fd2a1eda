"""Each job's output folder ``OUT/<name>/``: one per input, never shared, never another input's.

Names come from file and folder names (:func:`platypose.cli.terminal.safe_names.safe_name`), so two inputs can want the same
one (``x/a.mp4`` and ``y/a.mp4``), and a renamed one can want a name a third input has by itself (``a-2.mp4``).
Every input keeps its own name where it can; the others get the first ``NAME-2``, ``NAME-3``, ... that no input of
the batch wants (compared without case, for file systems that ignore it). A folder that an earlier run wrote for
another input (its ``lift.json`` or ``failed.json`` names other input files) is not used either: ``dayB/take1.mp4``
lifted alone with ``--resume`` does not run into the ``take1/`` of ``dayA/take1.mp4``.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import replace
from pathlib import Path

from platypose.cli.runs.jobs import Job, job_sources
from platypose.cli.runs.records import FAILURE, MANIFEST, read_record, valid_failure, valid_manifest
from platypose.cli.terminal.safe_names import distinct_names


def folder_owner(folder: Path) -> tuple[list[str] | None, str | None]:
    """(input files, input as given) recorded in ``folder``'s ``lift.json`` (else its ``failed.json``); (None, None)
    when neither is there (a damaged one is moved aside)."""
    for name, valid in ((MANIFEST, valid_manifest), (FAILURE, valid_failure)):
        record = read_record(folder / name, valid)
        if record is not None:
            sources = record.get("sources")
            given = record.get("input")
            return (sources if isinstance(sources, list) else None), (given if isinstance(given, str) else None)
    return None, None


def belongs_to(folder: Path, job: Job) -> bool:
    """Whether ``folder`` is free for ``job``: missing, without a record of a run, or a record of ``job``'s own input
    (the same files; records of older versions name the input only as it was given)."""
    if not folder.is_dir():
        return not folder.exists()
    sources, given = folder_owner(folder)
    if sources is not None:
        return sources == job_sources(job)
    return given is None or given == job.input


def claim_folders(jobs: Sequence[Job], out: Path) -> list[Job]:
    """``jobs`` renamed where their folder in ``out`` holds another input's run, or another job wants it."""
    names = distinct_names([job.name for job in jobs], lambda i, name: belongs_to(out / name, jobs[i]))
    return [job if name == job.name else replace(job, name=name) for job, name in zip(jobs, names)]
