"""Denoiser runtimes (float32, bfloat16, ONNX Runtime) and the device choice."""

from __future__ import annotations

import pytest
import torch

from platypose.lifting.errors import InputError
from platypose.lifting.prior.features import Normalizer
from platypose.lifting.prior.model import MotionPrior, PriorBundle, PriorConfig
from platypose.lifting.prior.runtime import (
    BFloat16Denoiser,
    OnnxDenoiser,
    auto_runtime,
    resolve_device,
    resolve_runtime,
    with_runtime,
)
from platypose.lifting.settings import PriorSettings

TINY = PriorConfig(layers=2, width=64, heads=4, ff_width=128, max_frames=16, dropout=0.0)


@pytest.fixture(scope="module")
def network() -> MotionPrior:
    """An untrained tiny network (runtimes must agree whatever the weights)."""
    torch.manual_seed(0)
    return MotionPrior(TINY).eval()


def _relative_error(a: torch.Tensor, b: torch.Tensor) -> float:
    return float((a - b).norm() / b.norm())


def test_inference_path_equals_the_encoder_modules(network) -> None:
    """Without autograd the network runs its own fused layers; they give the modules' x0 up to float rounding."""
    x = torch.randn(5, 13, TINY.features)
    with torch.inference_mode():
        fused = network(x, torch.tensor(7))
    modules = network(x, torch.tensor(7))  # autograd on: the nn.TransformerEncoder path
    assert modules.requires_grad and not fused.requires_grad
    assert _relative_error(fused, modules.detach()) < 1e-5


def test_inference_path_runs_float32_only(network, monkeypatch) -> None:
    """bfloat16 keeps torch's encoder-layer kernel (faster there than the fused path's attention)."""
    import platypose.lifting.prior.model as prior_module

    fused = prior_module.encode_for_inference
    calls = []
    monkeypatch.setattr(prior_module, "encode_for_inference", lambda *args: calls.append(args[1].dtype) or fused(*args))
    x = torch.randn(2, 8, TINY.features)
    with torch.inference_mode():
        network(x, torch.tensor(3))
        BFloat16Denoiser(network)(x, torch.tensor(3))
    assert calls == [torch.float32]


def test_onnx_runtime_matches_torch_for_any_batch_and_each_window_length(network) -> None:
    """ONNX Runtime's x0 equals torch's to float rounding; one export per window length, any batch size."""
    onnx = OnnxDenoiser(network, threads=1)
    for batch, frames in ((3, 16), (5, 16), (2, 7)):
        x = torch.randn(batch, frames, TINY.features)
        with torch.inference_mode():
            expected = network(x, torch.tensor(11))
        result = onnx(x, torch.tensor(11))
        assert result.shape == expected.shape and result.dtype == torch.float32
        assert _relative_error(result, expected) < 1e-5, (batch, frames)
    assert sorted(onnx.sessions) == [7, 16]


def test_bfloat16_runtime_is_close_but_not_equal(network) -> None:
    """bfloat16 keeps about 3 significant digits: close to float32, not identical, output in float32."""
    x = torch.randn(4, 16, TINY.features)
    with torch.inference_mode():
        expected = network(x, torch.tensor(5))
        result = BFloat16Denoiser(network)(x, torch.tensor(5))
    assert result.dtype == torch.float32
    assert 0 < _relative_error(result, expected) < 0.05


def test_with_runtime_swaps_only_the_network(network) -> None:
    """float32 is the bundle itself; other runtimes keep normaliser and config; unknown ones are refused."""
    bundle = PriorBundle(network, Normalizer(mean=torch.zeros(51).numpy(), std=torch.ones(51).numpy()))
    assert with_runtime(bundle, "float32") is bundle
    swapped = with_runtime(bundle, "bfloat16")
    assert isinstance(swapped.model, BFloat16Denoiser)
    assert swapped.normalizer is bundle.normalizer and swapped.config == bundle.config
    assert swapped.device == torch.device("cpu")
    with pytest.raises(InputError, match="unknown runtime 'int8'"):
        with_runtime(bundle, "int8")


def test_auto_runtime_follows_the_cpus_flags_not_a_timing(network, tmp_path, monkeypatch) -> None:
    """auto is bfloat16 on a CPU with AMX-BF16 (its flag in /proc/cpuinfo), else float32, and so the same on a
    machine whatever its load; a GPU and a system without the list keep float32."""
    import platypose.lifting.prior.runtime as runtime_module

    bundle = PriorBundle(network, Normalizer(mean=torch.zeros(51).numpy(), std=torch.ones(51).numpy()))
    flags = {"amx": "flags\t\t: fpu avx2 avx512f avx512_bf16 amx_bf16 amx_tile\n", "avx": "flags\t\t: fpu avx2\n"}
    for name, text in flags.items():
        (tmp_path / name).write_text(text)
    picked = {}
    for name in (*flags, "missing"):
        monkeypatch.setattr(runtime_module, "CPU_FLAGS", tmp_path / name)
        auto_runtime.cache_clear()
        picked[name] = auto_runtime("cpu")
        assert resolve_runtime("auto", torch.device("cpu")) == picked[name] and auto_runtime("cuda") == "float32"
        chosen = with_runtime(bundle, "auto")
        assert (chosen is bundle) if picked[name] == "float32" else isinstance(chosen.model, BFloat16Denoiser)
    auto_runtime.cache_clear()
    assert picked == {"amx": "bfloat16", "avx": "float32", "missing": "float32"}
    assert resolve_runtime("onnx", torch.device("cpu")) == "onnx" and PriorSettings().runtime == "auto"


def test_device_choice() -> None:
    """cpu always works; auto falls back to cpu without a GPU; cuda without one and unknown names are refused."""
    assert resolve_device("cpu") == torch.device("cpu")
    assert resolve_device("auto").type == ("cuda" if torch.cuda.is_available() else "cpu")
    if not torch.cuda.is_available():
        with pytest.raises(InputError, match="no CUDA GPU"):
            resolve_device("cuda")
    with pytest.raises(InputError, match="unknown device 'tpu'"):
        resolve_device("tpu")


def test_eval_cli_runs_with_a_runtime_and_device(run_cli, prior_file, data_dir) -> None:
    """``platypose eval --runtime onnx --device cpu`` prints its table; a bad runtime is a one-line error."""
    motion = data_dir / "motion" / "deepmimic"
    args = [
        "eval",
        motion,
        "--prior",
        prior_file,
        "--frames",
        "4",
        "--samples",
        "2",
        "--windows",
        "1",
        "--no-baseline",
        "--steps",
        "3",
        "--skip",
        "1",
        "--k",
        "1",
        "--device",
        "cpu",
    ]
    code, stdout, _ = run_cli(*args, "--runtime", "onnx")
    assert code == 0 and "platypose" in stdout
    code, _, stderr = run_cli(*args, "--runtime", "int8")
    assert code == 2 and "unknown --runtime 'int8'" in stderr


def test_lift_cli_device_option(run_cli, prior_file, data_dir, tmp_path) -> None:
    """``platypose lift --device cpu`` lifts one view of real keypoints; an unknown device is refused before any work."""
    take = data_dir / "video" / "pose2sim-balancing"
    args = [
        "lift",
        "--cams",
        take / "calib_pose2sim.toml",
        "--keypoints",
        take / "openpose-body25b" / "cam01_json",
        "--prior",
        prior_file,
        "--out",
        tmp_path,
        "--samples",
        "2",
        "--steps",
        "3",
        "--skip",
        "1",
        "--guidance-iters",
        "1",
        "--formats",
        "npz",
        "--persons",
        "largest",
        "--threads",
        "1",
        "--quiet",
    ]
    code, stdout, stderr = run_cli(*args, "--device", "cpu")
    assert code == 0, stderr
    assert "1 ok, 0 failed" in stdout
    code, _, stderr = run_cli(*args, "--device", "tpu")
    assert code == 2 and "unknown --device 'tpu'" in stderr and len(stderr.strip().splitlines()) == 1
