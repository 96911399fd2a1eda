"""Measuring the guided sampler from outside: network time, guidance time, analytic FLOPs and a matmul reference.

The network is timed by a thin wrapper around ``prior.model.forward``; guidance
is the rest of each diffusion step (energy, directions, root solve, DDIM). FLOPs
are counted analytically from the prior's config (matrix products only), so the
achieved GFLOP/s can be set against a large float32 ``torch.mm`` timed in the
same process with the same thread count, between the sampler's runs.
"""

from __future__ import annotations

import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from dataclasses import dataclass

import numpy as np
import torch

from platypose.lifting.calibration.defaults import default_camera
from platypose.lifting.camera import Camera, project
from platypose.lifting.prior.features import features_to_joints
from platypose.lifting.prior.model import MotionPrior, PriorBundle, PriorConfig
from platypose.lifting.sampling.sampler import cameras_and_rays, network_steps, sample
from platypose.lifting.settings import SamplerConfig

BENCH_IMAGE_SIZE = (1080, 1920)  # (height, width) of the synthetic view
BENCH_DISTANCE_M = 4.0  # person in front of the camera
BENCH_SPEED_M_S = 1.0  # sideways walk across the view


def network_flops(config: PriorConfig, frames: int, batch: int) -> float:
    """Floating-point operations of one forward pass over ``batch`` windows of ``frames`` frames (matrix products).

    Per token and layer: QKV and output projections 4 d^2, feed-forward 2 d ff and
    attention (scores and weighted sum) 2 L d multiply-adds over L = frames + 1
    tokens; plus the input and output layers (d x features per frame) and the step
    MLP (2 d^2 per window); each multiply-add counts 2. Norms, softmax and
    activations are left out.
    """
    d, ff, tokens = config.width, config.ff_width, frames + 1
    per_layer = tokens * (4 * d * d + 2 * d * ff + 2 * tokens * d)
    io = 2 * frames * config.features * d + 2 * d * d
    return 2.0 * batch * (config.layers * per_layer + io)


@contextmanager
def timed_forward(model: MotionPrior, device: torch.device = torch.device("cpu")) -> Iterator[list[float]]:
    """Record the seconds of every ``model.forward`` call into the yielded list while the context is open.

    On a GPU each call is synchronised before and after, so its seconds are its own.
    """
    durations: list[float] = []
    forward = model.forward

    def timed(*args, **kwargs):
        synchronize(device)
        started = time.perf_counter()
        result = forward(*args, **kwargs)
        synchronize(device)
        durations.append(time.perf_counter() - started)
        return result

    model.forward = timed
    try:
        yield durations
    finally:
        del model.forward  # back to the class's method


def synchronize(device: torch.device) -> None:
    """Wait for the device's queued work (CUDA runs asynchronously; a no-op on the CPU)."""
    if device.type == "cuda":
        torch.cuda.synchronize(device)


def matmul_probe(
    size: int, device: torch.device = torch.device("cpu"), runtime: str = "float32"
) -> Callable[[], float]:
    """A function timing one product of two ``size`` x ``size`` matrices; returns GFLOP/s.

    ``runtime`` is the network's: ``float32`` and ``bfloat16`` time ``torch.mm`` in that dtype on
    ``device``, ``onnx`` an ONNX Runtime MatMul (float32, torch's thread count), so the reference
    runs the kernels the network runs.
    """
    generator = torch.Generator().manual_seed(0)
    a = torch.randn(size, size, generator=generator)
    b = torch.randn(size, size, generator=generator)
    if runtime == "onnx":
        multiply = onnx_matmul(a.numpy(), b.numpy())
    else:
        dtype = torch.bfloat16 if runtime == "bfloat16" else torch.float32
        a, b = a.to(device=device, dtype=dtype), b.to(device=device, dtype=dtype)

        def multiply() -> None:
            torch.mm(a, b)

    def probe() -> float:
        synchronize(device)
        started = time.perf_counter()
        multiply()
        synchronize(device)
        return 2.0 * size**3 / (time.perf_counter() - started) / 1e9

    return probe


def onnx_matmul(a: np.ndarray, b: np.ndarray) -> Callable[[], None]:
    """A function running ``a @ b`` (float32) in an ONNX Runtime session with torch's thread count."""
    import onnx
    import onnxruntime
    from onnx import TensorProto, helper

    inputs = [helper.make_tensor_value_info(n, TensorProto.FLOAT, list(x.shape)) for n, x in (("a", a), ("b", b))]
    output = helper.make_tensor_value_info("c", TensorProto.FLOAT, [a.shape[0], b.shape[1]])
    graph = helper.make_graph([helper.make_node("MatMul", ["a", "b"], ["c"])], "matmul", inputs, [output])
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    options = onnxruntime.SessionOptions()
    options.intra_op_num_threads = torch.get_num_threads()
    options.inter_op_num_threads = 1
    session = onnxruntime.InferenceSession(
        onnx.shape_inference.infer_shapes(model).SerializeToString(), options, providers=["CPUExecutionProvider"]
    )
    feed = {"a": np.ascontiguousarray(a, dtype=np.float32), "b": np.ascontiguousarray(b, dtype=np.float32)}

    def multiply() -> None:
        session.run(None, feed)

    return multiply


def walking_view(prior: PriorBundle, frames: int) -> tuple[list[Camera], np.ndarray]:
    """One default camera and the pixels ``(1, 1, frames, 17, 3)`` (x, y, confidence 1) of a person walking past it.

    The person is the prior's mean pose, ``BENCH_DISTANCE_M`` in front of the camera,
    moving sideways at ``BENCH_SPEED_M_S``; sampler timing does not depend on the pose.
    """
    camera = default_camera("bench", *BENCH_IMAGE_SIZE)
    pose = features_to_joints(np.asarray(prior.normalizer.mean, dtype=np.float64))  # (17, 3)
    pose = pose - pose[0]
    walk = np.arange(frames)[:, None] / prior.fps * BENCH_SPEED_M_S * np.array([1.0, 0.0, 0.0])
    joints = pose[None] + walk[:, None] + np.array([0.0, BENCH_DISTANCE_M, 0.0])  # camera looks along +Y
    pixels = project(joints, camera)
    keypoints = np.concatenate([pixels, np.ones((frames, 17, 1))], axis=-1)
    return [camera], keypoints[None, None]


@dataclass(frozen=True)
class SamplerTiming:
    """The median timed run: seconds per run, per diffusion step, and its network (one call) and guidance parts."""

    calls: int
    run_s: float
    step_s: float
    network_step_s: float
    guidance_step_s: float
    flops_per_call: float

    @property
    def network_gflops(self) -> float:
        """Achieved GFLOP/s of the network."""
        return self.flops_per_call / self.network_step_s / 1e9


def time_sampler(
    prior: PriorBundle, config: SamplerConfig, frames: int, repeats: int, between: Callable[[], object] | None = None
) -> SamplerTiming:
    """Time ``sample`` on one synthetic window of ``frames`` frames: a warm-up run, then the median of ``repeats``.

    ``between`` is called after each timed run, outside the timing (a reference
    measured this way sees the same load as the sampler on a shared machine).
    """
    cameras, keypoints = walking_view(prior, frames)
    obs, rays = cameras_and_rays(cameras, keypoints[..., :2], keypoints[..., 2], device=prior.device)
    calls = len(network_steps(prior, config))
    sample(prior, obs, rays, config, frames)
    runs, networks = [], []
    with timed_forward(prior.model, prior.device) as durations:
        for _ in range(repeats):
            durations.clear()
            started = time.perf_counter()
            sample(prior, obs, rays, config, frames)
            runs.append(time.perf_counter() - started)
            networks.append(sum(durations))
            if between is not None:
                between()
    middle = sorted(range(repeats), key=runs.__getitem__)[(repeats - 1) // 2]  # the median run (lower for even)
    run_s, network_s = runs[middle], networks[middle]
    return SamplerTiming(
        calls=calls,
        run_s=run_s,
        step_s=run_s / calls,
        network_step_s=network_s / calls,
        guidance_step_s=(run_s - network_s) / calls,
        flops_per_call=network_flops(prior.config, frames, config.samples),
    )
