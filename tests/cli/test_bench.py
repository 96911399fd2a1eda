"""``platypose bench``: analytic FLOPs against torch's counter, the forward timer, the looped clip, the report."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from platypose.cli.runs.bench_clip import loop_video
from platypose.lifting.offline.benchmark import matmul_probe, network_flops, onnx_matmul, timed_forward, walking_view
from platypose.lifting.prior.model import MotionPrior, PriorBundle, PriorConfig, save_prior

TINY = PriorConfig(layers=2, width=64, heads=4, ff_width=128, max_frames=16, dropout=0.0)
QUICK = ["--samples", "2", "--frames", "4", "--steps", "1", "--k", "1", "--repeats", "1", "--matmul-size", "64"]


@pytest.fixture(scope="module")
def tiny_prior(data_dir):
    """An untrained tiny prior (timing does not depend on the weights) normalised on real walking (DeepMimic)."""
    from platypose.lifting.motion_io import load_motion_paths
    from platypose.lifting.prior.features import Normalizer, joints_to_features

    walk = next(m for m in load_motion_paths([data_dir / "motion" / "deepmimic"]) if "walk" in m.name)
    torch.manual_seed(0)
    model = MotionPrior(TINY).eval()
    return PriorBundle(model, Normalizer.fit(joints_to_features(walk.joints[None, :16])))


@pytest.fixture(scope="module")
def tiny_prior_path(tiny_prior, tmp_path_factory) -> Path:
    """The tiny prior written to a checkpoint file for the CLI."""
    path = tmp_path_factory.mktemp("bench") / "tiny.pt"
    save_prior(path, tiny_prior)
    return path


@pytest.mark.parametrize(
    "config, frames, batch", [(TINY, 8, 3), (PriorConfig(layers=3, width=96, heads=2, ff_width=80), 13, 2)]
)
def test_network_flops_match_torch_flop_counter(config, frames, batch) -> None:
    """The analytic count equals torch's FLOP counter over the real forward pass (math attention, so it is counted)."""
    from torch.nn.attention import SDPBackend, sdpa_kernel
    from torch.utils.flop_counter import FlopCounterMode

    model = MotionPrior(config).train()  # the training path runs attention as countable matrix products
    with sdpa_kernel(SDPBackend.MATH), FlopCounterMode(display=False) as counter, torch.no_grad():
        model(torch.randn(batch, frames, config.features), torch.tensor(7))
    assert network_flops(config, frames, batch) == counter.get_total_flops()


def test_timed_forward_records_each_call_and_restores_the_method() -> None:
    """Every forward call is timed, outputs are unchanged, and the class's forward is back afterwards."""
    model = MotionPrior(TINY).eval()
    x = torch.randn(2, 5, TINY.features)
    with torch.no_grad():
        expected = model(x, torch.tensor(3))
        with timed_forward(model) as durations:
            outputs = [model(x, torch.tensor(3)) for _ in range(3)]
    assert len(durations) == 3 and min(durations) > 0
    assert all(torch.equal(out, expected) for out in outputs)
    assert "forward" not in vars(model)


def test_matmul_references_run_each_runtimes_kernel() -> None:
    """The ONNX Runtime product is the matrix product; every runtime's probe gives a positive rate."""
    gen = np.random.default_rng(0)
    a, b = gen.standard_normal((5, 7)).astype(np.float32), gen.standard_normal((7, 3)).astype(np.float32)
    captured = []
    import onnxruntime

    run = onnxruntime.InferenceSession.run
    try:
        onnxruntime.InferenceSession.run = lambda self, *args: captured.append(run(self, *args)[0])
        onnx_matmul(a, b)()
    finally:
        onnxruntime.InferenceSession.run = run
    np.testing.assert_allclose(captured[0], a @ b, rtol=1e-5)
    for runtime in ("float32", "bfloat16", "onnx"):
        assert matmul_probe(64, runtime=runtime)() > 0, runtime


def test_walking_view_is_a_person_inside_the_image(tiny_prior) -> None:
    """The synthetic view: all joints inside the 1920x1080 image, full confidence, pelvis moving right."""
    cameras, keypoints = walking_view(tiny_prior, 12)
    assert keypoints.shape == (1, 1, 12, 17, 3)
    pixels = keypoints[0, 0, ..., :2]
    assert (pixels[..., 0] > 0).all() and (pixels[..., 0] < cameras[0].width).all()
    assert (pixels[..., 1] > 0).all() and (pixels[..., 1] < cameras[0].height).all()
    assert (keypoints[..., 2] == 1).all()
    assert np.all(np.diff(pixels[:, 0, 0]) > 0)
    height = pixels[:, :, 1].max(axis=1) - pixels[:, :, 1].min(axis=1)
    assert 150 < height.mean() < 900  # a 1.5-1.9 m person at 4 m with a 2200 px focal length


def test_loop_video_repeats_the_source(data_dir, tmp_path) -> None:
    """A 102-frame loop of a 100-frame real video, read back with PyAV: 30 fps, frame 100 is the source's frame 0."""
    import av

    source = data_dir / "video" / "pose2sim-balancing" / "cam01.mp4"
    target = tmp_path / "loop.mp4"
    assert loop_video(source, target, 102, 30.0) == (1920, 1080)

    def gray_frames(path: Path) -> tuple[float, list[np.ndarray]]:
        with av.open(str(path)) as container:
            stream = container.streams.video[0]
            rate = float(stream.average_rate)
            return rate, [f.to_ndarray(format="gray") for f in container.decode(stream)]  # uint8, 2 MB each

    rate, looped = gray_frames(target)
    _, original = gray_frames(source)
    assert rate == 30.0 and len(looped) == 102 and looped[0].shape == (1920, 1080)

    def mae(a, b):
        return np.abs(a.astype(np.float64) - b).mean()

    assert mae(looped[100], original[0]) < 5 < mae(looped[100], original[99])
    assert mae(looped[101], original[1]) < 5
    assert mae(looped[99], original[99]) < 5


def test_bench_cli_reports_consistent_positive_figures(run_cli, tiny_prior_path, tmp_path) -> None:
    """Tiny sampler bench without the clip: every figure positive, JSON and table agree, parts add up."""
    out = tmp_path / "bench.json"
    code, stdout, _ = run_cli(
        "bench",
        "--prior",
        tiny_prior_path,
        "--samples",
        "4",
        "--frames",
        "8",
        "--steps",
        "2",
        "--k",
        "2",
        "--repeats",
        "2",
        "--matmul-size",
        "128",
        "--threads",
        "1",
        "--no-end-to-end",
        "--json",
        out,
        "-q",
    )
    assert code == 0
    report = json.loads(out.read_text())
    s = report["sampler"]
    assert (s["samples"], s["frames"], s["steps"], s["guidance_iters"], s["repeats"]) == (4, 8, 2, 2, 2)
    for key in (
        "run_s",
        "step_s",
        "network_step_s",
        "guidance_step_s",
        "hypothesis_frames_per_s",
        "network_gflop_per_step",
        "network_gflops",
        "matmul_gflops",
        "runtime_matmul_gflops",
        "utilisation",
    ):
        assert s[key] > 0, key
    assert s["network_gflop_per_step"] * 1e9 == network_flops(TINY, 8, 4)
    assert s["hypothesis_frames_per_s"] == pytest.approx(4 * 8 / s["run_s"])
    assert s["step_s"] == pytest.approx(s["run_s"] / 2)
    assert s["network_step_s"] + s["guidance_step_s"] == pytest.approx(s["step_s"])
    assert s["utilisation"] == pytest.approx(s["network_gflops"] / s["runtime_matmul_gflops"])  # like with like
    if s["runtime"] == "float32":
        assert s["runtime_matmul_gflops"] == s["matmul_gflops"]
    assert s["hypothesis_frames_per_matmul_gflop"] == pytest.approx(s["hypothesis_frames_per_s"] / s["matmul_gflops"])
    assert report["machine"]["threads"] == 1 and report["peak_rss_mb"] > 0
    assert report["prior"]["layers"] == 2 and report["prior"]["width"] == 64
    assert report["end_to_end"] is None
    assert s["runtime"] in ("float32", "bfloat16")  # what --runtime auto picked on this machine
    assert f"{s['hypothesis_frames_per_s']:.1f}" in stdout
    assert f"{100 * s['utilisation']:.1f} %" in stdout
    assert "end-to-end" not in stdout
    loaded = report["machine"]["load_average"][0] > report["machine"]["cores"]
    assert ("note: load average above the core count" in stdout) == loaded


def test_bench_cli_end_to_end_on_a_real_clip(run_cli, tiny_prior_path, data_dir, tmp_path) -> None:
    """Half a second of the real demo video: detected (one person or more), every person lifted where present, in
    lift's phases (the floor's quick lift, the lift, finishing); times and memory positive."""
    out = tmp_path / "bench.json"
    video = data_dir / "video" / "sports2d-demo" / "demo.mp4"
    args = ["--threads", "1", "--clip-seconds", "0.5", "--video", video, "--persons", "all", "--json", out, "-q"]
    code, stdout, _ = run_cli("bench", "--prior", tiny_prior_path, *QUICK, *args)
    assert code == 0
    e = json.loads(out.read_text())["end_to_end"]
    assert (e["frames"], e["fps"], e["hypotheses"], e["image_size"]) == (15, 30.0, 50, [994, 1768])
    assert e["tracks"] >= 1 and e["persons"] == "all" and e["persons_lifted"] == e["tracks"]
    assert 0 < e["person_frames"] <= e["frames"] * e["tracks"]
    assert e["lift_cpu_s_per_person_minute"] == pytest.approx(e["lift_cpu_s"] / (e["person_frames"] / 1800))
    assert e["detect_s"] > 0 and e["lift_s"] > 0 and e["total_s"] == pytest.approx(e["detect_s"] + e["lift_s"])
    assert 100 < e["detect_peak_rss_mb"] <= e["peak_rss_mb"]
    assert f"{e['lift_s']:.1f}" in stdout
    # lifted as platypose lift lifts it: the floor estimated under a quick lift, then the lift, then finishing
    assert list(e["phases"]) == ["detection", "floor quick lift", "lift", "finishing"]
    bounds = [t for span in e["phases"].values() for t in span]
    assert bounds == sorted(bounds) and bounds[-1] - bounds[2] == pytest.approx(e["lift_s"], abs=0.5)


@pytest.mark.parametrize(
    "args, message",
    [
        (["--frames", "17"], "--frames 17"),
        (["--steps", "49"], "--steps must be in 1..48"),
        (["--video", "missing.mp4"], "missing.mp4: video to loop not found"),
        (["--clip-seconds", "nan"], "--clip-seconds nan: give a length in seconds above 0, at most 600"),
        (["--clip-seconds", "1e308"], "--clip-seconds 1e+308: give a length in seconds above 0, at most 600"),
        (["--clip-seconds", "1e6"], "--clip-seconds 1e+06: give a length in seconds above 0, at most 600"),
        (["--clip-seconds", "0"], "--clip-seconds 0: give a length in seconds above 0, at most 600"),
        (["--persons", "tallest"], "--persons must be 'all', 'largest', 'largest:N' (the N largest)"),
    ],
)
def test_bench_cli_bad_input_exits_2(run_cli, tiny_prior_path, args, message) -> None:
    """Impossible sizes and a missing video are one-line errors with exit code 2."""
    code, _, stderr = run_cli("bench", "--prior", tiny_prior_path, *QUICK, "-q", *args)
    assert code == 2
    assert message in stderr and len(stderr.strip().splitlines()) == 1


def test_a_video_to_loop_that_is_no_file_is_named_for_what_it_is(tmp_path):
    import os

    from platypose.cli.commands_bench import check_video_to_loop
    from platypose.lifting.errors import InputError

    fifo = tmp_path / "clip.mp4"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match=r"clip.mp4: is a FIFO \(named pipe\), not a video file to loop"):
        check_video_to_loop(fifo)  # was "not found"
    (tmp_path / "folder").mkdir()
    with pytest.raises(InputError, match=r"folder: is a folder, not a video file to loop"):
        check_video_to_loop(tmp_path / "folder")
    with pytest.raises(InputError, match=r"gone.mp4: video to loop not found \(give --video\)"):
        check_video_to_loop(tmp_path / "gone.mp4")
    (tmp_path / "real.mp4").write_bytes(b"x")
    check_video_to_loop(tmp_path / "real.mp4")


def test_sigterm_while_the_clip_is_written_removes_it(tiny_prior_path, data_dir, tmp_path) -> None:
    """SIGTERM while the looped clip is being written ends bench with exit 130 and leaves nothing in TMPDIR."""
    import os
    import signal
    import subprocess
    import sys
    import time

    scratch = tmp_path / "tmp"
    scratch.mkdir()
    video = data_dir / "video" / "pose2sim-balancing" / "cam01.mp4"
    args = ["bench", "--prior", tiny_prior_path, *QUICK, "--threads", "1", "--clip-seconds", "600", "--video", video]
    env = {**os.environ, "TMPDIR": str(scratch), "OMP_NUM_THREADS": "1"}
    process = subprocess.Popen([sys.executable, "-m", "platypose", *map(str, args)], env=env, stderr=subprocess.PIPE)
    try:
        deadline = time.monotonic() + 120
        while not list(scratch.glob("platypose-bench-*/clip.mp4")) and time.monotonic() < deadline:
            time.sleep(0.2)
        assert list(scratch.glob("platypose-bench-*/clip.mp4")), "no clip was started"
        process.send_signal(signal.SIGTERM)
        _, err = process.communicate(timeout=60)
    finally:
        process.kill()
    assert process.returncode == 130, err
    assert "interrupted; the temporary clip was removed" in err.decode() and "Traceback" not in err.decode()
    assert list(scratch.iterdir()) == []
