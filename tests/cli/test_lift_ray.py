"""``platypose lift --executor ray`` on a local Ray cluster started in this module (a 2-CPU head): the same outputs
and summary as a local run for a good, a corrupt and an empty video, worker processes killed mid-input (retried, or
recorded as failed), a node lost mid-input (retried on the head), Ctrl-C, outputs collected to the driver, one
detector and prior load per worker."""

from __future__ import annotations

import _thread
import json
import os
import signal
import threading
import time
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import ray
from export_helpers import read_entities

from platypose.cli.commands_lift import lift_settings
from platypose.cli.runs import ray as lift_ray
from platypose.cli.runs.batch import SUMMARY_LOCK, run_batch
from platypose.cli.runs.jobs import discover_jobs
from platypose.cli.runs.ray import RayExecutor, RayOptions

STORE = 80 * 1024**2  # object store bytes per node


@pytest.fixture(scope="module")
def cluster():
    """A local Ray cluster for the module: a head node of 2 CPUs (more nodes can be added), no dashboard, no usage
    statistics, small object stores."""
    from ray.cluster_utils import Cluster

    os.environ["RAY_USAGE_STATS_ENABLED"] = "0"
    head = {"num_cpus": 2, "object_store_memory": STORE, "include_dashboard": False}
    nodes = Cluster(initialize_head=True, head_node_args=head)
    ray.init(address=nodes.address, log_to_driver=False, logging_level="WARNING")
    yield nodes
    ray.shutdown()
    nodes.shutdown()


def test_the_address_probe_passes_a_real_cluster(cluster) -> None:
    """The probe's GetClusterId call is answered by a real Ray GCS, at its address and at 127.0.0.1 (which Ray
    dials as this machine's address)."""
    from platypose.cli.runs.ray_address import check_ray_address

    port = cluster.address.rsplit(":", 1)[1]
    check_ray_address(cluster.address, timeout_s=5)
    check_ray_address(f"127.0.0.1:{port}", timeout_s=5)


def batch_args(batch_folder, prior_file, out, *extra: str) -> tuple[str, ...]:
    common = ("--prior", prior_file, "--samples", "4", "--seed", "3", "--threads", "1", "--persons", "largest")
    return ("lift", str(batch_folder), *common, "--out", str(out), "--quiet", *extra)


def comparable(entries: list[dict], out: Path) -> list[dict]:
    """Summary entries without their seconds, output paths relative to ``out``."""
    return [dict(e, seconds=None, outputs=[str(Path(p).relative_to(out)) for p in e["outputs"]]) for e in entries]


def assert_same_outputs(local: Path, other: Path) -> None:
    """Every file of a local run's output folder is in ``other`` with the same content: bytes, or for the npz every
    array and its meta but timings and arguments, for the rrd every entity's columns but the recording's start
    time (rerun's reader)."""
    files = sorted(p.relative_to(local) for p in local.rglob("*") if p.is_file() and p.name != "summary.json")
    assert files == sorted(p.relative_to(other) for p in other.rglob("*") if p.is_file() and p.name != "summary.json")
    for name in files:
        a, b = local / name, other / name
        if name.suffix == ".npz" and not name.name.endswith(".detections.npz"):
            x, y = np.load(a), np.load(b)
            assert x.files == y.files
            for key in x.files:
                if key == "meta":
                    drop = ("timings", "arguments")
                    mx, my = ({k: v for k, v in json.loads(str(z["meta"])).items() if k not in drop} for z in (x, y))
                    assert mx == my
                else:
                    assert np.array_equal(x[key], y[key], equal_nan=x[key].dtype.kind == "f"), key
        elif name.suffix == ".rrd":
            x, y = read_entities(a), read_entities(b)
            for entities in (x, y):  # when the recording was made
                entities["/__properties"].pop("static:RecordingInfo:start_time")
            assert x == y
        elif name.name in ("log.txt", "lift.json"):  # timings; the output folder's path
            assert b.stat().st_size > 0
        else:
            assert a.read_bytes() == b.read_bytes(), name


def staging_left(out: Path) -> list[str]:
    """Hidden entries in ``out`` other than the summary's lock file (staging folders of runs)."""
    return sorted(p.name for p in out.glob(".*") if p.name != SUMMARY_LOCK)


@pytest.fixture(scope="module")
def local_run(batch_folder, prior_file, tmp_path_factory):
    """The batch lifted with ``--executor local`` (one process): its output folder and summary entries."""
    import subprocess
    import sys

    out = tmp_path_factory.mktemp("local")
    args = batch_args(batch_folder, prior_file, out)
    done = subprocess.run([sys.executable, "-m", "platypose", *args], capture_output=True, text=True)
    assert done.returncode == 2, done.stderr  # every failure is bad input
    return out, json.loads((out / "summary.json").read_text())["inputs"]


@pytest.mark.parametrize("collect", [False, True], ids=["shared-out", "collect"])
def test_ray_batch_equals_local_batch(cluster, run_cli, batch_folder, prior_file, local_run, tmp_path, collect):
    local, local_entries = local_run
    extra = ("--executor", "ray", *(["--collect"] if collect else []))
    code, out, _ = run_cli(*batch_args(batch_folder, prior_file, tmp_path, *extra))
    assert code == 2 and "3 input(s): 1 ok, 2 failed, 0 skipped" in out
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert comparable(summary["inputs"], tmp_path) == comparable(local_entries, local)
    assert summary["counts"] == {"ok": 1, "failed": 2, "skipped": 0}
    assert_same_outputs(local, tmp_path)
    manifest = json.loads((tmp_path / "good" / "lift.json").read_text())
    assert manifest["outputs"] and all(
        (tmp_path / "good" / p).is_file() and p == Path(p).name for p in manifest["outputs"]
    )
    assert staging_left(tmp_path) == [] and not list(tmp_path.rglob(".*.tmp"))

    stamps = {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*") if p.is_file() and p.name != "summary.json"}
    code, out, _ = run_cli(*batch_args(batch_folder, prior_file, tmp_path, *extra), "--resume")
    assert code == 2 and "0 ok, 2 failed, 1 skipped" in out
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps


def ray_settings(prior_file: str, out: Path):
    """The RunSettings of ``batch_args`` (for run_batch called directly)."""
    from platypose.lifting.settings import DetectOptions, PriorSettings, SamplerConfig, WindowSettings

    prior, sampler = PriorSettings(Path(prior_file)), SamplerConfig(samples=4, seed=3)
    detect, formats = DetectOptions(threads=1), "npz,csv,bvh,rrd"
    return lift_settings(
        out=out,
        cams=None,
        prior=prior,
        detect=detect,
        sampler=sampler,
        windows=WindowSettings(),
        formats=formats,
        persons="largest",
        root="auto",
        root_file=None,
        quiet=True,
        arguments={},
    )


def kill_worker_when_staging(out: Path, name: str, killed: list[int]) -> threading.Thread:
    """A thread that kills (SIGKILL) the Ray worker process running job ``name`` once its staging folder exists in
    ``out``; the pid goes into ``killed``."""

    def worker_pids() -> list[int]:
        pids = []
        for entry in Path("/proc").iterdir():
            try:
                if entry.name.isdigit() and (entry / "cmdline").read_bytes().startswith(f"ray::lift:{name}".encode()):
                    pids.append(int(entry.name))
            except OSError:
                continue
        return pids

    def kill() -> None:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            pids = worker_pids() if list(out.glob(f".{name}.*.partial")) else []
            if pids:
                os.kill(pids[0], signal.SIGKILL)
                killed.append(pids[0])
                return
            time.sleep(0.01)

    thread = threading.Thread(target=kill, daemon=True)
    thread.start()
    return thread


@pytest.mark.parametrize("retries", [1, 0])
def test_worker_killed_mid_input_is_retried_or_recorded(
    cluster, batch_folder, prior_file, local_run, tmp_path, retries
):
    local, _ = local_run
    jobs = [j for j in discover_jobs([batch_folder]) if j.name == "good"]
    settings = ray_settings(prior_file, tmp_path)
    killed: list[int] = []
    killer = kill_worker_when_staging(tmp_path, "good", killed)
    executor = RayExecutor(RayOptions(max_retries=retries))
    [entry] = run_batch(jobs, settings, executor=executor)
    killer.join()
    assert len(killed) == 1 and f"{ray.util.get_node_ip_address()}:{killed[0]}" not in executor.workers
    assert staging_left(tmp_path) == []  # the killed attempt's staging folder is gone
    if retries:
        assert entry["status"] == "ok" and entry["error"] is None
        assert_same_outputs(local / "good", tmp_path / "good")
    else:
        assert entry["status"] == "failed" and entry["error"].startswith("Ray gave up after 1 attempt(s): ")
        assert "died" in entry["error"] and "\n" not in entry["error"]
        assert not (tmp_path / "good" / "lift.json").exists()
        assert json.loads((tmp_path / "good" / "failed.json").read_text())["error"] == entry["error"]

    stamps = {p: p.stat().st_mtime_ns for p in tmp_path.rglob("*") if p.is_file() and p.name != "summary.json"}
    executor = RayExecutor(RayOptions())
    [again] = run_batch(jobs, settings, resume=True, executor=executor)
    assert again["status"] == ("skipped" if retries else "failed") and executor.workers == {}
    assert {p: p.stat().st_mtime_ns for p in stamps} == stamps


def test_node_lost_mid_input_is_retried_on_another_node(cluster, batch_folder, prior_file, local_run, tmp_path):
    from ray.util.scheduling_strategies import NodeAffinitySchedulingStrategy

    def hold(seconds: float) -> None:  # defined here: sent to the worker by value
        time.sleep(seconds)

    local, _ = local_run
    node = cluster.add_node(num_cpus=2, object_store_memory=STORE)
    cluster.wait_for_nodes()
    on_head = NodeAffinitySchedulingStrategy(ray.get_runtime_context().get_node_id(), soft=False)
    blocker = ray.remote(num_cpus=2)(hold).options(scheduling_strategy=on_head).remote(600)
    deadline = time.monotonic() + 60
    while ray.available_resources().get("CPU", 0) > 2 and time.monotonic() < deadline:
        time.sleep(0.05)  # the head is busy: the input goes to the new node
    lost: list[bool] = []

    def lose_node_when_lifting() -> None:
        while time.monotonic() < deadline and not list(tmp_path.glob(".good.*.partial")):
            time.sleep(0.01)
        lost.append(bool(list(tmp_path.glob(".good.*.partial"))))
        cluster.remove_node(node)
        ray.cancel(blocker, force=True)  # the head is free for the second attempt

    thread = threading.Thread(target=lose_node_when_lifting, daemon=True)
    thread.start()
    jobs = [j for j in discover_jobs([batch_folder]) if j.name == "good"]
    executor = RayExecutor(RayOptions(cpus_per_input=2, max_retries=1))
    [entry] = run_batch(jobs, ray_settings(prior_file, tmp_path), executor=executor)
    thread.join()
    assert lost == [True] and entry["status"] == "ok" and entry["error"] is None
    assert_same_outputs(local / "good", tmp_path / "good")
    assert staging_left(tmp_path) == []


@pytest.fixture
def ctrl_c_raises():
    """Python's own SIGINT handler (KeyboardInterrupt), also when the tests run with SIGINT ignored (started in
    the background by a shell); the earlier handler is restored after the test."""
    previous = signal.signal(signal.SIGINT, signal.default_int_handler)
    yield
    signal.signal(signal.SIGINT, previous)


@pytest.mark.parametrize("grace", [10.0, 0.0], ids=["tasks-clean-up", "workers-ended"])
def test_ctrl_c_cancels_tasks_and_keeps_what_finished(
    cluster, batch_folder, prior_file, local_run, tmp_path, ctrl_c_raises, monkeypatch, grace
):
    """Ctrl-C: the running lift is cancelled, nothing of it is left (its task removes its staging folder, or, past
    the grace period, its worker is ended and the driver removes it); what finished is recorded."""
    monkeypatch.setattr(lift_ray, "CANCEL_GRACE_S", grace)
    local, _ = local_run
    jobs = discover_jobs([batch_folder])
    settings = ray_settings(prior_file, tmp_path)
    # good lifts for a long while, also on a loaded machine
    slower = replace(settings, take=replace(settings.take, sampler=replace(settings.take.sampler, samples=5000)))

    def interrupt_when_lifting() -> None:
        deadline = time.monotonic() + 60
        while time.monotonic() < deadline:
            if list(tmp_path.glob(".good.*.partial")):
                _thread.interrupt_main()  # as Ctrl-C in a terminal: SIGINT's handler runs in the main thread
                return
            time.sleep(0.01)

    threading.Thread(target=interrupt_when_lifting, daemon=True).start()
    with pytest.raises(KeyboardInterrupt):
        run_batch(jobs, slower, executor=RayExecutor(RayOptions(cpus_per_input=2)))
    entries = json.loads((tmp_path / "summary.json").read_text())["inputs"]
    assert [e["name"] for e in entries] == ["corrupt", "empty"]  # good was running: cancelled, not recorded
    assert not (tmp_path / "good" / "lift.json").exists() and staging_left(tmp_path) == []

    entries = run_batch(jobs, settings, resume=True, executor=RayExecutor(RayOptions()))
    assert [e["status"] for e in entries] == ["failed", "failed", "ok"]
    assert_same_outputs(local / "good", tmp_path / "good")


def test_detector_and_prior_load_once_per_worker(cluster, batch_folder, prior_file, tmp_path):
    """Two inputs in one Ray worker process: the runner's own code loads the detector and the prior once."""

    def two_inputs_counting_loads(jobs, settings) -> dict:
        import platypose.detectors.models.contracts as contracts
        import platypose.lifting.prior.runtime as runtime
        from platypose.cli.runs.models import cached_detector, loaded_prior
        from platypose.cli.runs.ray import lift_on_worker

        counts = {"detector": 0, "prior": 0}
        patched = [(contracts, "load_detector", "detector"), (runtime, "load_for_runtime", "prior")]
        originals = [getattr(module, name) for module, name, _ in patched]

        def counting(original, key):
            def wrapper(*args, **kwargs):
                counts[key] += 1
                return original(*args, **kwargs)

            return wrapper

        cached_detector.cache_clear()
        loaded_prior.cache_clear()
        for (module, name, key), original in zip(patched, originals):
            setattr(module, name, counting(original, key))
        try:
            statuses = [lift_on_worker(job, settings, 1, os.getcwd(), False)[0]["status"] for job in jobs]
        finally:
            for (module, name, _), original in zip(patched, originals):
                setattr(module, name, original)
        return dict(counts, statuses=statuses)

    good = next(j for j in discover_jobs([batch_folder]) if j.name == "good")
    jobs = [good, type(good)("good-again", good.input, good.views)]
    task = ray.remote(num_cpus=2)(two_inputs_counting_loads)
    counts = ray.get(task.remote(jobs, ray_settings(prior_file, tmp_path)))
    assert counts == {"detector": 1, "prior": 1, "statuses": ["ok", "ok"]}


def test_ray_options_are_checked_before_any_work(cluster, run_cli, batch_folder, prior_file, tmp_path):
    code, _, err = run_cli(
        *batch_args(batch_folder, prior_file, tmp_path, "--executor", "ray", "--cpus-per-input", "3")
    )
    assert code == 2 and "--cpus-per-input 3: the largest Ray node has 2 CPU(s)" in err
    assert not (tmp_path / "summary.json").exists()  # no empty summary of a batch that never started
    code, _, err = run_cli(*batch_args(batch_folder, prior_file, tmp_path, "--executor", "ray", "--jobs", "2"))
    assert code == 2 and "--jobs is for --executor local" in err
    code, _, err = run_cli(*batch_args(batch_folder, prior_file, tmp_path, "--collect"))
    assert code == 2 and "--collect: only with --executor ray" in err
    assert not (tmp_path / "good").exists()


def test_without_ray_the_error_says_how_to_install(run_cli, monkeypatch, batch_folder, prior_file, tmp_path):
    import sys

    monkeypatch.setitem(sys.modules, "ray", None)  # import ray -> ImportError
    code, _, err = run_cli(*batch_args(batch_folder, prior_file, tmp_path, "--executor", "ray"))
    assert code == 2 and "pip install 'platypose[ray]'" in err
    assert not (tmp_path / "summary.json").exists()
