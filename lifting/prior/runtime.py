"""Where and how the denoiser runs: the device, and float32 / bfloat16 / ONNX Runtime runners.

``auto`` (the default) runs the network in bfloat16 on CPUs that multiply bfloat16 matrices in hardware (read from
the CPU's flags, :func:`auto_runtime`: the same choice on a machine whatever its load), else float32.

A runner has the network's call signature ``(x_t (B, F, D), t) -> x0 (B, F, D)`` and its
``config``, so :func:`with_runtime` can swap it into a :class:`~lifting.prior.model.PriorBundle`
without the sampler knowing. Guidance always runs in float32 on the observations' device.
"""

from __future__ import annotations

import copy
import functools
import io
import warnings
from dataclasses import replace
from pathlib import Path

import numpy as np
import torch
from torch import nn

from platypose.lifting.errors import InputError
from platypose.lifting.prior.model import MotionPrior, PriorBundle, load_prior
from platypose.lifting.settings import DEVICES, RUNTIMES, PriorSettings


def resolve_device(name: str) -> torch.device:
    """``cpu``, ``cuda`` or ``auto`` (cuda when available, else cpu) -> a torch device; InputError otherwise."""
    if name not in DEVICES:
        raise InputError(f"unknown device {name!r}; choose {', '.join(DEVICES)}")
    if name == "auto":
        return torch.device("cuda" if torch.cuda.is_available() else "cpu")
    if name == "cuda" and not torch.cuda.is_available():
        raise InputError("device cuda: this torch build sees no CUDA GPU (choose cpu or auto)", option="device")
    return torch.device(name)


class BFloat16Denoiser(nn.Module):
    """The network with bfloat16 weights and activations; inputs and outputs stay in the caller's dtype."""

    def __init__(self, model: MotionPrior) -> None:
        super().__init__()
        self.config = model.config
        self.network = copy.deepcopy(model).to(torch.bfloat16).eval()

    def forward(self, x_t: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """``x0`` predicted in bfloat16, returned as ``x_t.dtype``."""
        return self.network(x_t.to(torch.bfloat16), t).to(x_t.dtype)


class OnnxDenoiser(nn.Module):
    """The network exported to ONNX and run by ONNX Runtime on the CPU (one export per window length).

    torch's ONNX exporter fixes the attention's sequence length, so each window length
    gets its own export (about a second, once); the batch stays dynamic.
    """

    def __init__(self, model: MotionPrior, threads: int | None = None) -> None:
        super().__init__()
        self.config = model.config
        self.network = model
        self.threads = threads or torch.get_num_threads()
        self.sessions: dict[int, object] = {}

    def session(self, frames: int):
        """The ONNX Runtime session for windows of ``frames`` frames (exported on first use)."""
        if frames not in self.sessions:
            import onnxruntime

            options = onnxruntime.SessionOptions()
            options.intra_op_num_threads = self.threads
            options.inter_op_num_threads = 1
            self.sessions[frames] = onnxruntime.InferenceSession(
                export_onnx(self.network, frames), options, providers=["CPUExecutionProvider"]
            )
        return self.sessions[frames]

    def forward(self, x_t: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """``x0`` from ONNX Runtime, as a tensor on ``x_t``'s device and dtype."""
        batch, frames, _ = x_t.shape
        steps = np.broadcast_to(np.asarray(torch.as_tensor(t).cpu(), dtype=np.int64), (batch,))
        feed = {"x_t": x_t.detach().cpu().to(torch.float32).numpy(), "t": np.ascontiguousarray(steps)}
        (x0,) = self.session(frames).run(None, feed)
        return torch.from_numpy(x0).to(device=x_t.device, dtype=x_t.dtype)


def export_onnx(model: MotionPrior, frames: int) -> bytes:
    """The network as ONNX bytes for windows of ``frames`` frames, any batch (inputs ``x_t`` and ``t``, output ``x0``)."""
    example = torch.zeros(2, frames, model.config.features)
    steps = torch.zeros(2, dtype=torch.int64)
    buffer = io.BytesIO()
    fastpath = torch.backends.mha.get_fastpath_enabled()
    torch.backends.mha.set_fastpath_enabled(False)  # the fused inference kernel has no ONNX form
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", torch.jit.TracerWarning)  # shape checks traced as constants: intended
            warnings.simplefilter("ignore", DeprecationWarning)  # the legacy exporter: the new one needs onnxscript
            torch.onnx.export(
                model.eval(),
                (example, steps),
                buffer,
                input_names=["x_t", "t"],
                output_names=["x0"],
                dynamic_axes={"x_t": {0: "batch"}, "t": {0: "batch"}, "x0": {0: "batch"}},
                opset_version=17,
                dynamo=False,
            )
    except ImportError as err:
        raise InputError(f"runtime onnx needs the onnx package to export the prior ({err})", option="runtime") from None
    finally:
        torch.backends.mha.set_fastpath_enabled(fastpath)
    return buffer.getvalue()


CPU_FLAGS = Path("/proc/cpuinfo")  # Linux's list of what this CPU does in hardware


@functools.cache
def auto_runtime(device_type: str = "cpu") -> str:
    """``bfloat16`` on a CPU that multiplies bfloat16 matrices in hardware (Intel's AMX-BF16 tiles, flag ``amx_bf16`` in
    ``/proc/cpuinfo``: a product of the network's shape, 2048 x 256 by 256 x 768, ran 7.6-11.6 times as fast in bfloat16
    as in float32 on such a CPU), else ``float32`` (and always on a GPU). Read from the CPU's flags, not timed: a timing
    taken on a busy machine picked either, and a lift's result then depended on the machine's load (two runs of one lift
    0.5-0.7 m apart)."""
    if device_type != "cpu":
        return "float32"
    try:
        flags = CPU_FLAGS.read_text(errors="replace").split()
    except OSError:  # not Linux: no list to read; float32 everywhere gives the same numbers
        return "float32"
    return "bfloat16" if "amx_bf16" in flags else "float32"


def resolve_runtime(runtime: str, device: torch.device) -> str:
    """``runtime`` with ``auto`` replaced by what :func:`auto_runtime` picks on ``device``."""
    return auto_runtime(device.type) if runtime == "auto" else runtime


def with_runtime(prior: PriorBundle, runtime: str, threads: int | None = None) -> PriorBundle:
    """The prior with its network run by ``runtime`` (``float32``: unchanged; ``auto``: :func:`auto_runtime`);
    InputError for an unknown one."""
    if runtime not in RUNTIMES:
        raise InputError(f"unknown runtime {runtime!r}; choose {', '.join(RUNTIMES)}")
    runtime = resolve_runtime(runtime, prior.device)
    if runtime == "float32":
        return prior
    if prior.device.type != "cpu":
        raise InputError(f"runtime {runtime} runs on the CPU only (the prior is on {prior.device})", option="runtime")
    model = BFloat16Denoiser(prior.model) if runtime == "bfloat16" else OnnxDenoiser(prior.model, threads)
    return replace(prior, model=model)


def load_for_runtime(
    path: str | Path | None, device: str = "cpu", runtime: str = "auto", threads: int | None = None
) -> PriorBundle:
    """Load a prior (default: the shipped one) onto ``device`` (cpu, cuda, auto) with its network run by ``runtime``."""
    prior, _ = load_prior(path, resolve_device(device))
    return with_runtime(prior, runtime, threads)


def load_settings(settings: PriorSettings, threads: int | None = None) -> PriorBundle:
    """The prior ``settings`` name, ready to sample (:func:`load_for_runtime`)."""
    return load_for_runtime(settings.path, settings.device, settings.runtime, threads)
