"""``platypose lift --executor ray``: one Ray task per input, on a local Ray instance or on a Ray cluster.

Each task runs the same ``run_job`` as a local batch (detection, lifting and
export of one input stay together), so outputs, ``lift.json``, ``failed.json``
and ``log.txt`` are those of a local run. Outputs are written by the worker into
``--out`` (shared storage, the default: nothing large moves through Ray), or,
with ``collect``, into a folder of the worker's own and sent back to the
driver, which writes them into ``--out`` (lift.json last, each file atomically).

A worker process keeps the prior and the detector it loaded for the inputs that
follow (the runner's caches live as long as the process, and Ray reuses worker
processes for tasks of the same kind). A worker that dies or a node that is
lost is retried ``max_retries`` times by Ray, then the input is recorded as
failed (with ``failed.json``, so ``--resume`` leaves it alone unless
``--retry-failed``). Ctrl-C cancels the tasks, waits briefly for running ones
to clean their staging folders (ending the workers of those that do not, and removing what they left), records
whatever finished, and re-raises.
"""

from __future__ import annotations

import os
import signal
import tempfile
import threading
import time
from collections.abc import Callable, Iterator, Sequence
from contextlib import ExitStack, contextmanager
from dataclasses import dataclass, replace
from pathlib import Path

from platypose.cli.runs.fingerprint import fingerprint
from platypose.cli.runs.job import JOB_LOCK, job_entry, run_job
from platypose.cli.runs.jobs import Job
from platypose.cli.runs.locks import Busy, exclusive_lock
from platypose.cli.runs.outputs import remove_stale_outputs, remove_stale_staging
from platypose.cli.runs.ray_address import check_ray_address
from platypose.cli.runs.records import FAILURE, MANIFEST, write_failure
from platypose.cli.runs.settings import RunSettings
from platypose.cli.runs.workers import limit_threads
from platypose.cli.terminal.console import say_over_bar
from platypose.lifting.errors import InputError

INSTALL_HINT = "--executor ray needs Ray on the driver and every worker: pip install 'platypose[ray]'"
CANCEL_GRACE_S = 10.0  # after Ctrl-C: how long running tasks get to remove their staging folders, then to end
POLL_S = 0.25  # how often the driver wakes: the bar's running / failed counts, and how soon Ctrl-C is seen


@dataclass(frozen=True)
class RayOptions:
    """Where and how inputs run on Ray.

    ``address``: None starts a private Ray instance on this machine (``num_cpus``
    of it, default all cores), even when a cluster runs here; "auto" joins the
    cluster this machine belongs to (``ray start``, or ``RAY_ADDRESS``);
    "ray://host:10001" connects through Ray Client.
    """

    address: str | None = None
    cpus_per_input: int = 1
    max_retries: int = 2
    collect: bool = False
    num_cpus: int | None = None
    object_store_memory: int | None = None


def import_ray():
    """The ``ray`` module; InputError saying how to install it when it is missing."""
    try:
        import ray
    except ImportError:
        raise InputError(INSTALL_HINT) from None
    return ray


@contextmanager
def connected(options: RayOptions, quiet: bool) -> Iterator[object]:
    """Ray initialised for ``options`` (no usage statistics, no dashboard); shut down after if we started it."""
    os.environ.setdefault("RAY_USAGE_STATS_ENABLED", "0")  # before Ray reads its settings
    ray = import_ray()
    if ray.is_initialized():
        yield ray
        return
    local = options.address is None
    if not local:
        check_ray_address(options.address)  # a deadline and one line, before Ray's own minutes of retries
    settings = {
        "address": "local" if local else options.address,  # "local": never join a cluster found on this machine
        "log_to_driver": False,
        "logging_level": "ERROR" if quiet else "INFO",  # -q: not even Ray's token-authentication warning
    }
    if local:
        settings.update(
            include_dashboard=False,
            num_cpus=options.num_cpus,
            object_store_memory=options.object_store_memory,
        )
    ours = signal.getsignal(signal.SIGTERM)  # the batch's: SIGTERM stops it as Ctrl-C does (exit 130)
    try:
        ray.init(**settings)
    except (ConnectionError, ValueError) as err:
        raise InputError(
            f"--ray-address {options.address}: could not connect ({' '.join(str(err).split())}); is the cluster "
            "up, and with Ray's token authentication is RAY_AUTH_MODE=token set here (docs/ray.md)?"
        ) from None
    finally:
        if ours is not None and threading.current_thread() is threading.main_thread():
            signal.signal(signal.SIGTERM, ours)  # Ray's own handler dumps a native stack and exits 1
    try:
        yield ray
    finally:
        ray.shutdown()


def lift_on_worker(job: Job, settings: RunSettings, threads: int, cwd: str, collect: bool):
    """Run on a Ray worker: one job -> (summary entry, {relative path: bytes} when ``collect``, worker "ip:pid").

    ``cwd`` is the driver's working folder: relative paths mean the same on a node that has it.
    """
    import ray

    if os.path.isdir(cwd):
        os.chdir(cwd)
    limit_threads(threads)
    worker = f"{ray.util.get_node_ip_address()}:{os.getpid()}"
    if not collect:
        remove_stale_staging(settings.out, job.name, owners_gone=True)  # a retry: the earlier attempt died
        return run_job(job, settings), None, worker
    with tempfile.TemporaryDirectory(prefix="platypose-lift-") as scratch:
        entry = run_job(job, replace(settings, out=Path(scratch)))
        folder = Path(scratch) / job.name
        files = {str(p.relative_to(folder)): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}
    return entry, files, worker


def write_collected(folder: Path, entry: dict, files: dict[str, bytes], say=say_over_bar) -> dict:
    """Write a job's collected ``files`` into ``folder`` atomically, ``lift.json`` last (its output names are
    relative to its folder, so it holds as it was written on the worker), removing the outputs of an earlier run
    that this one did not write, as a local run does; the entry with paths in ``folder``. Another run writing the
    folder is waited for, and ``say`` says so."""
    from platypose.lifting.files.atomic import atomic_open

    folder.mkdir(parents=True, exist_ok=True)
    with ExitStack() as held:
        try:
            held.enter_context(exclusive_lock(folder / JOB_LOCK, wait=False))
        except Busy:
            say(f"{folder.name}: another platypose run is writing {folder}/ now; waiting for it to end")
            held.enter_context(exclusive_lock(folder / JOB_LOCK))  # never mixes with it
        (folder / MANIFEST).unlink(missing_ok=True)  # the old set is no longer whole from here
        files = {n: content for n, content in files.items() if n != JOB_LOCK}
        if entry["status"] == "ok":
            stale = remove_stale_outputs(folder, entry["name"], [folder / n for n in files])
            if stale and "log.txt" in files:
                line = f"removed output(s) of an earlier run that this run did not write: {', '.join(stale)}\n"
                files["log.txt"] += line.encode()
        for relative in sorted(files, key=lambda name: name == MANIFEST):
            with atomic_open(folder / relative) as stream:
                stream.write(files[relative])
    entry = dict(entry, outputs=[str(folder / Path(p).name) for p in entry["outputs"]])
    if entry["status"] == "ok":
        (folder / FAILURE).unlink(missing_ok=True)
    return entry


def ray_failure(err: BaseException) -> str:
    """One line for a Ray error: the task's own exception, or what happened to its worker or node."""
    cause = getattr(err, "cause", None)
    if isinstance(cause, BaseException):
        return f"{type(cause).__name__}: {' '.join(str(cause).split())}"
    first = next((line.strip() for line in str(err).splitlines() if line.strip()), "")
    return f"{type(err).__name__}: {first}"


def check_fits(ray, cpus_per_input: int) -> None:
    """InputError when no node of the cluster has ``cpus_per_input`` CPUs (the tasks would wait forever)."""
    biggest = max((n["Resources"].get("CPU", 0) for n in ray.nodes() if n["Alive"]), default=0)
    if biggest < cpus_per_input:
        raise InputError(f"--cpus-per-input {cpus_per_input}: the largest Ray node has {biggest:g} CPU(s)")


class RayExecutor:
    """Runs a batch's jobs as Ray tasks: ``executor(jobs, todo, settings, record, bar)``, like the process pool.

    ``record(index, entry)`` is called on the driver as each input finishes; ``bar`` is the batch's progress bar,
    whose label shows how many inputs are running and how many failed. ``workers`` counts the inputs each
    worker process ("ip:pid") ran.
    """

    def __init__(self, options: RayOptions) -> None:
        self.options = options
        self.workers: dict[str, int] = {}

    def __call__(
        self,
        jobs: Sequence[Job],
        todo: Sequence[int],
        settings: RunSettings,
        record: Callable[[int, dict], None],
        bar,
    ) -> None:
        if not todo:
            return
        o = self.options
        threads = settings.detect.threads or o.cpus_per_input
        worker_settings = replace(settings, detect=replace(settings.detect, threads=threads), quiet=True)
        with connected(o, settings.quiet) as ray:
            check_fits(ray, o.cpus_per_input)
            task = ray.remote(num_cpus=o.cpus_per_input, max_retries=o.max_retries, retry_exceptions=False)(
                lift_on_worker
            )
            shared = ray.put(worker_settings)
            cwd = os.getcwd()
            started = time.perf_counter()
            refs = {
                task.options(name=f"lift:{jobs[i].name}").remote(jobs[i], shared, threads, cwd, o.collect): i
                for i in todo
            }
            pending, failed = list(refs), 0

            def show(left: int, done: int) -> None:
                bar.label = f"inputs ({self._running(ray, left)} running, {failed} failed)"
                bar.update(done)  # renders the label too

            def finish(ref, left: int) -> None:
                nonlocal failed
                index = refs[ref]
                entry = self._entry(ray, ref, jobs[index], settings, time.perf_counter() - started)
                failed += entry["status"] == "failed"
                record(index, entry)
                show(left, 1)

            try:
                while pending:
                    done, pending = ray.wait(pending, num_returns=len(pending), timeout=POLL_S)
                    for ref in done:
                        finish(ref, len(pending))
                    if not done:
                        show(len(pending), 0)
            except BaseException:
                for ref in pending:
                    ray.cancel(ref)
                done, late = ray.wait(pending, num_returns=len(pending), timeout=CANCEL_GRACE_S)
                if late:  # still running after the grace: their workers are ended
                    for ref in late:
                        ray.cancel(ref, force=True)
                    ray.wait(late, num_returns=len(late), timeout=CANCEL_GRACE_S)
                for ref in pending:
                    try:
                        ray.get(ref, timeout=0)
                    except ray.exceptions.RayError:  # GetTimeoutError too
                        # cancelled or ended: nothing of it is kept, not even a staging folder its worker left
                        remove_stale_staging(settings.out, jobs[refs[ref]].name, owners_gone=True)
                        continue
                    finish(ref, 0)
                raise

    def _running(self, ray, pending: int) -> int:
        """Inputs running now: the cluster's CPUs in use over CPUs per input (at most the ones not finished)."""
        total, free = ray.cluster_resources().get("CPU", 0), ray.available_resources().get("CPU", 0)
        return min(pending, int(round((total - free) / self.options.cpus_per_input)))

    def _entry(self, ray, ref, job: Job, settings: RunSettings, seconds: float) -> dict:
        """The summary entry of a finished task; a task Ray gave up on is recorded as failed, with failed.json
        (``seconds``: since the batch's tasks were submitted)."""
        try:
            entry, files, worker = ray.get(ref)
        except ray.exceptions.RayError as err:
            if isinstance(err, ray.exceptions.RayTaskError):  # the task's own exception: not retried
                error = f"Ray task failed: {ray_failure(err)}"
            else:  # its worker or node died on every attempt
                error = f"Ray gave up after {self.options.max_retries + 1} attempt(s): {ray_failure(err)}"
            entry = job_entry(job, "failed", seconds=round(seconds, 2), error=error)
            remove_stale_staging(settings.out, job.name, owners_gone=True)
            record_failure(job, settings, error)
            return entry
        self.workers[worker] = self.workers.get(worker, 0) + 1
        if files is not None:
            entry = write_collected(settings.out / job.name, entry, files)
        return entry


def record_failure(job: Job, settings: RunSettings, error: str) -> None:
    """Write ``OUT/<name>/failed.json`` for a job whose worker never returned, as the runner does for its own."""
    write_failure(settings.out / job.name, job, error, fingerprint(job, settings), transient=False)
