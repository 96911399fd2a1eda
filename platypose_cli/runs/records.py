"""The batch's bookkeeping files in ``--out`` (``lift.json``, ``failed.json``, ``summary.json``), read defensively,
and the records of a job's earlier run that ``--resume`` reads: its failure, the flags it said.

They are only read as regular files of bounded size (a FIFO in their place would block the lift). A damaged one
(not JSON, nested too deep, too large, not a regular file, or not the structure platypose writes) is moved aside
as ``NAME.damaged`` with one warning, and the lift goes on as if it were missing: a damaged file must not fail
every later lift into that ``--out``.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path

import typer

from platypose.cli.runs.jobs import Job, job_sources
from platypose.cli.terminal.safe_names import printable
from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import write_text_atomic
from platypose.lifting.files.reads import read_regular

MAX_RECORD_BYTES = 64 * 2**20  # a summary of tens of thousands of inputs
MANIFEST = "lift.json"
FAILURE = "failed.json"


def _strings(value: object) -> bool:
    return isinstance(value, list) and all(isinstance(v, str) for v in value)


def valid_manifest(record: dict) -> bool:
    """Whether ``record`` has the fields of a ``lift.json`` that ``--resume`` reads."""
    return _strings(record.get("outputs")) and _strings(record.get("formats"))


def valid_failure(record: dict) -> bool:
    """Whether ``record`` has the fields of a ``failed.json``."""
    return all(isinstance(record.get(k), str) for k in ("error", "fingerprint"))


def valid_summary(record: dict) -> bool:
    """Whether ``record`` is a ``summary.json``: a list of entries, each with a name and a known status."""
    inputs = record.get("inputs")
    return isinstance(inputs, list) and all(
        isinstance(e, dict) and isinstance(e.get("name"), str) and e.get("status") in ("ok", "failed", "skipped")
        for e in inputs
    )


def read_record(path: Path, valid: Callable[[dict], bool]) -> dict | None:
    """The JSON object in ``path`` if ``valid`` accepts it; None when there is none, or when it is damaged: then
    it is moved aside to ``NAME.damaged`` and one warning says so."""
    if not os.path.lexists(path):
        return None
    try:
        record = json.loads(read_regular(path, MAX_RECORD_BYTES, "bookkeeping file").decode("utf-8"))
        why = None if isinstance(record, dict) and valid(record) else "not the fields platypose writes"
    except InputError as err:
        why = str(err).removeprefix(f"{path}: ")
    except (ValueError, RecursionError):  # also UnicodeDecodeError
        why = "not valid JSON"
    except OSError as err:
        why = err.strerror or str(err)
    if why is None:
        return record
    aside = path.with_name(path.name + ".damaged")
    try:
        os.replace(path, aside)
        where = f"moved aside to {aside.name}"
    except OSError as err:
        where = f"ignored (it cannot be moved aside: {err.strerror or err})"
    typer.echo(printable(f"warning: {path}: damaged ({why}); {where}"), err=True)
    return None


def flag_lines(reports: list[dict]) -> list[str]:
    """The console's lines about a lift's flagged persons, from its plausibility ``reports`` (:func:`lifting.checks.flags.person_lines`)."""
    from platypose.lifting.checks.flags import person_lines

    return person_lines(reports, [report["track_id"] for report in reports])


def earlier_flags(folder: Path) -> list[str]:
    """The flag lines the finished earlier run in ``folder`` kept in its lift.json (none from older versions)."""
    flags = (read_record(folder / MANIFEST, valid_manifest) or {}).get("flags")
    return flags if isinstance(flags, list) and all(isinstance(line, str) for line in flags) else []


def write_failure(folder: Path, job: Job, error: str, digest: str, transient: bool) -> None:
    """Record a failed run of ``job`` in ``folder/failed.json``: its error, the fingerprint of its inputs and
    settings, and whether the failure was transient (retried by ``--resume``)."""
    failure = {"input": job.input, "sources": job_sources(job), "error": error, "fingerprint": digest}
    failure["transient"] = transient
    write_text_atomic(folder / FAILURE, json.dumps(failure, indent=1))


def earlier_failure(folder: Path, digest: str) -> str | None:
    """The error of an earlier failed run of the same input and settings in ``folder`` that was not transient
    (a full disk, an I/O error: worth retrying), else None."""
    failure = read_record(folder / FAILURE, valid_failure)  # a damaged one is moved aside with a warning
    if failure is None or failure["fingerprint"] != digest or failure.get("transient"):
        return None
    return failure["error"]
