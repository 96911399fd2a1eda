"""A batch of lift jobs: resume, sequential or parallel runs, progress, and ``OUT/summary.json`` after every input.

The runner's interface: jobs (and settings) in, one summary entry per job out, in job order.

Each input gets ``--threads`` threads for torch and onnxruntime, by default one
(:mod:`platypose.cli.runs.workers`), with ``--jobs J`` in each of J worker processes. ``summary.json`` is
rewritten under a lock (``OUT/.summary.lock``) and merged with the entries that
other runs into the same OUT wrote meanwhile (entries of other inputs are kept,
this run's replace the same inputs'). Ctrl-C (or SIGTERM) stops the batch: inputs
that finished are recorded, running workers are ended (each removes its staging
folder), and KeyboardInterrupt is raised.
"""

from __future__ import annotations

import json
import os
import sys
import time
from collections.abc import Callable, Sequence
from dataclasses import replace
from pathlib import Path

import typer

from platypose.cli.runs.fingerprint import fingerprint
from platypose.cli.runs.job import job_entry, run_job
from platypose.cli.runs.jobs import Job
from platypose.cli.runs.locks import exclusive_lock
from platypose.cli.runs.outputs import finished_outputs, remove_stale_staging
from platypose.cli.runs.records import MANIFEST, earlier_failure, earlier_flags, flag_lines, read_record, valid_summary
from platypose.cli.runs.settings import RunSettings
from platypose.cli.runs.workers import limit_threads, terminate_as_interrupt, threads_for, worker_init
from platypose.cli.terminal.console import say_over_bar
from platypose.cli.terminal.safe_names import printable

SUMMARY = "summary.json"


SUMMARY_LOCK = ".summary.lock"  # in OUT, beside summary.json


def _other_entries(out: Path, mine: list[dict]) -> list[dict]:
    """Entries of ``OUT/summary.json`` (another run's) for inputs this run does not have (a damaged summary is moved
    aside with a warning)."""
    earlier = read_record(out / SUMMARY, valid_summary)
    names = {e["name"] for e in mine}
    return [e for e in (earlier or {}).get("inputs", []) if e["name"] not in names]


def write_summary(out: Path, entries: list[dict], started: str, arguments: dict) -> Path:
    """Write ``OUT/summary.json`` atomically under a lock: other runs' entries for other inputs first, then this
    run's in job order; counts per status; this run's arguments."""
    from platypose.lifting.files.atomic import write_text_atomic

    with exclusive_lock(out / SUMMARY_LOCK):  # POSIX; elsewhere no lock
        inputs = _other_entries(out, entries) + entries
        counts = {s: sum(e["status"] == s for e in inputs) for s in ("ok", "failed", "skipped")}
        summary = {
            "inputs": inputs,
            "counts": counts,
            "started": started,
            "updated": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "arguments": arguments,
        }
        return write_text_atomic(out / SUMMARY, json.dumps(summary, indent=1) + "\n")


def run_batch(
    jobs: Sequence[Job],
    settings: RunSettings,
    *,
    workers: int = 1,
    resume: bool = False,
    say: Callable[[str], None] = lambda _: None,
    retry_failed: bool = False,
    executor: Callable | None = None,
) -> list[dict]:
    """Run ``jobs``; the summary entries in job order, summary.json kept current.

    ``resume`` skips finished inputs, and inputs that failed before with the same files and settings (unless
    ``retry_failed``): they keep status "failed" with the earlier error, and nothing is run for them.

    Ctrl-C stops the batch after writing the summary of what finished (KeyboardInterrupt is re-raised).
    ``executor(jobs, todo, settings, record, bar)``, when given, runs the jobs instead of this machine's
    processes (``platypose.cli.runs.ray.RayExecutor``).
    """
    started = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    entries: dict[int, dict] = {}
    todo = []
    for index, job in enumerate(jobs):
        if not resume:
            todo.append(index)
            continue
        folder = settings.out / job.name
        digest = fingerprint(job, settings)
        outputs, why = finished_outputs(folder, settings.formats, digest)
        failed = earlier_failure(folder, digest) if not retry_failed else None
        if outputs is not None:
            remove_stale_staging(settings.out, job.name)  # a killed run's staging folder goes even when skipped
            entries[index] = {**job_entry(job, "skipped", outputs), "reason": why}
            say(f"{job.name}: skipped, {why} ({len(outputs)} files)")
            for flagged in earlier_flags(folder):  # what that run found, as it said it
                say_over_bar(printable(f"  {job.name}: {flagged}"))
        elif failed is not None:
            entries[index] = {**job_entry(job, "failed", error=f"earlier run: {failed}"), "error_kind": "input"}
            say(f"{job.name}: not retried, failed earlier with the same files and settings (--retry-failed)")
        else:
            todo.append(index)
            say(f"{job.name}: run, {why}")

    def record(index: int, entry: dict) -> None:
        entries[index] = entry
        write_summary(settings.out, [entries[i] for i in sorted(entries)], started, settings.arguments)
        line = f"{jobs[index].name}: {entry['status']} in {entry['seconds']:.1f} s"
        say(line + (f": {entry['error']}" if entry["error"] else ""))
        for flagged in flag_lines(entry.get("plausibility", [])):  # shown even with --quiet
            say_over_bar(f"  {jobs[index].name}: {flagged}")

    settings.out.mkdir(parents=True, exist_ok=True)
    if entries:  # inputs --resume settled; else the first input to finish writes it (a batch that fails to start,
        # such as --cpus-per-input beyond every Ray node, leaves no empty summary)
        write_summary(settings.out, [entries[i] for i in sorted(entries)], started, settings.arguments)
    hidden = settings.quiet or not todo
    bar_options = {"length": len(todo), "label": "inputs", "file": sys.stderr, "hidden": hidden, "show_eta": True}
    with terminate_as_interrupt(), typer.progressbar(**bar_options) as bar:
        if executor is not None:
            executor(jobs, todo, settings, record, bar)
        elif workers <= 1 or len(todo) <= 1:
            threads = threads_for(settings.detect.threads)
            limit_threads(threads)
            here = replace(settings, detect=replace(settings.detect, threads=threads))  # the detector's too
            for index in todo:
                record(index, run_job(jobs[index], here))
                bar.update(1)
        else:
            _run_parallel(jobs, todo, settings, workers, record, bar)
    return [entries[i] for i in sorted(entries)]


def _finished_meanwhile(job: Job, settings: RunSettings, since: float) -> dict | None:
    """An ok entry for ``job`` if this batch finished it (a lift.json with its fingerprint written after ``since``)."""
    folder = settings.out / job.name
    outputs, _ = finished_outputs(folder, settings.formats, fingerprint(job, settings))
    if outputs is None or (folder / MANIFEST).stat().st_mtime < since:
        return None
    return job_entry(job, "ok", outputs)


def _run_parallel(jobs, todo, settings: RunSettings, workers: int, record, bar) -> None:
    """Run ``todo`` jobs in ``workers`` spawned processes with a per-process thread cap; per-video bars are off."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    threads = threads_for(settings.detect.threads)
    worker_settings = replace(settings, detect=replace(settings.detect, threads=threads), quiet=True)
    context = multiprocessing.get_context("spawn")
    recorded: set[int] = set()
    began = time.time()

    def take(future) -> None:
        index = futures[future]
        try:
            entry = future.result()
        except Exception as err:
            error = f"worker process failed: {type(err).__name__}: {err}"
            entry = {**job_entry(jobs[index], "failed", error=error), "error_kind": "internal"}
        recorded.add(index)
        record(index, entry)
        bar.update(1)

    pool = ProcessPoolExecutor(workers, mp_context=context, initializer=worker_init, initargs=(threads, os.getpid()))
    futures = {pool.submit(run_job, jobs[i], worker_settings): i for i in todo}
    try:
        for future in as_completed(futures):
            take(future)
    except BaseException:
        # Ctrl-C: keep what finished, drop what did not start, end the running workers (SIGTERM: they clean up).
        for future in futures:
            if future.done() and not future.cancelled() and futures[future] not in recorded:
                take(future)
        for future in futures:
            future.cancel()
        for process in list((getattr(pool, "_processes", None) or {}).values()):
            process.terminate()
        pool.shutdown(wait=True, cancel_futures=True)
        for index in todo:  # finished in a worker whose answer had not arrived yet: its lift.json says so
            if index not in recorded:
                entry = _finished_meanwhile(jobs[index], settings, began)
                if entry is not None:
                    recorded.add(index)
                    record(index, entry)
        raise
    pool.shutdown(wait=True)
