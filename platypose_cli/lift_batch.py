"""A batch of lift jobs: resume, sequential or parallel runs, progress, and ``OUT/summary.json`` after every input.

With ``--jobs J`` each worker process gets ``cores // J`` threads for torch and
onnxruntime, so J workers never oversubscribe the machine.
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

from platypose.cli.lift_jobs import Job
from platypose.cli.lift_run import (
    RunSettings,
    earlier_failure,
    fingerprint,
    finished_outputs,
    job_entry,
    run_job,
)
from platypose.lifting.plausibility import plausibility_lines

SUMMARY = "summary.json"


def threads_per_job(jobs: int) -> int:
    """Threads each of ``jobs`` parallel workers may use: ``cores // jobs``, at least 1."""
    return max(1, (os.cpu_count() or 1) // max(1, jobs))


def limit_threads(threads: int) -> None:
    """Cap torch's (and OpenMP's) threads in this process."""
    os.environ["OMP_NUM_THREADS"] = str(threads)
    import torch

    torch.set_num_threads(threads)


def write_summary(out: Path, entries: list[dict], started: str, arguments: dict) -> Path:
    """Write ``OUT/summary.json`` atomically: inputs in job order, counts per status, arguments."""
    from platypose.lifting.atomic import write_text_atomic

    counts = {s: sum(e["status"] == s for e in entries) for s in ("ok", "failed", "skipped")}
    summary = {
        "inputs": entries,
        "counts": counts,
        "started": started,
        "updated": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        "arguments": arguments,
    }
    return write_text_atomic(out / SUMMARY, json.dumps(summary, indent=1) + "\n")


def run_batch(
    jobs: Sequence[Job],
    settings: RunSettings,
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
    processes (``platypose.cli.lift_ray.RayExecutor``).
    """
    started = time.strftime("%Y-%m-%dT%H:%M:%S%z")
    entries: dict[int, dict] = {}
    todo = []
    for index, job in enumerate(jobs):
        folder = settings.out / job.name
        outputs = finished_outputs(folder, settings.formats) if resume else None
        failed = earlier_failure(folder, fingerprint(job, settings)) if resume and not retry_failed else None
        if outputs is not None:
            entries[index] = job_entry(job, "skipped", outputs)
            say(f"{job.name}: skipped, finished earlier ({len(outputs)} files)")
        elif failed is not None:
            entries[index] = job_entry(job, "failed", error=f"earlier run: {failed}")
            say(f"{job.name}: not retried, failed earlier with the same files and settings (--retry-failed)")
        else:
            todo.append(index)

    def record(index: int, entry: dict) -> None:
        entries[index] = entry
        write_summary(settings.out, [entries[i] for i in sorted(entries)], started, settings.arguments)
        line = f"{jobs[index].name}: {entry['status']} in {entry['seconds']:.1f} s"
        say(line + (f": {entry['error']}" if entry["error"] else ""))
        persons = entry.get("plausibility", [])
        for flagged in plausibility_lines(persons, [p["track_id"] for p in persons]):  # shown even with --quiet
            typer.echo(f"  {jobs[index].name}: {flagged}", err=True)

    settings.out.mkdir(parents=True, exist_ok=True)
    write_summary(settings.out, [entries[i] for i in sorted(entries)], started, settings.arguments)
    hidden = settings.quiet or not todo
    with typer.progressbar(length=len(todo), label="inputs", file=sys.stderr, hidden=hidden, show_eta=True) as bar:
        if executor is not None:
            executor(jobs, todo, settings, record, bar)
        elif workers <= 1 or len(todo) <= 1:
            limit_threads(settings.detect.threads or threads_per_job(1))
            for index in todo:
                record(index, run_job(jobs[index], settings))
                bar.update(1)
        else:
            _run_parallel(jobs, todo, settings, workers, record, bar)
    return [entries[i] for i in sorted(entries)]


def _run_parallel(jobs, todo, settings: RunSettings, workers: int, record, bar) -> None:
    """Run ``todo`` jobs in ``workers`` spawned processes with a per-process thread cap; per-video bars are off."""
    import multiprocessing
    from concurrent.futures import ProcessPoolExecutor, as_completed

    threads = settings.detect.threads or threads_per_job(workers)
    worker_settings = replace(settings, detect=replace(settings.detect, threads=threads), quiet=True)
    context = multiprocessing.get_context("spawn")
    with ProcessPoolExecutor(workers, mp_context=context, initializer=limit_threads, initargs=(threads,)) as pool:
        futures = {pool.submit(run_job, jobs[i], worker_settings): i for i in todo}
        try:
            for future in as_completed(futures):
                index = futures[future]
                try:
                    entry = future.result()
                except Exception as err:
                    error = f"worker process failed: {type(err).__name__}: {err}"
                    entry = job_entry(jobs[index], "failed", error=error)
                record(index, entry)
                bar.update(1)
        except BaseException:
            pool.shutdown(wait=True, cancel_futures=True)
            raise
