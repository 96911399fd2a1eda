"""The motion prior: an MDM-style encoder-only transformer that predicts x0, and its checkpoint.

One token per frame (linear in/out), the diffusion step as an extra first
token (sinusoidal embedding -> 2 linear layers with SiLU), sinusoidal
positions, no text conditioning. A checkpoint is one file holding the config,
frame rate, joint set, normalisation, weights and the data manifest; loading
is strict and refuses files that are not ours.
"""

from __future__ import annotations

import hashlib
import io
import json
import math
import re
from dataclasses import asdict, dataclass, field
from pathlib import Path

import numpy as np
import torch
from torch import nn

from platypose.lifting.errors import InputError
from platypose.lifting.files.atomic import atomic_open
from platypose.lifting.files.reads import read_regular
from platypose.lifting.prior.checks import (
    CONFIG_BOUNDS,
    check_config,
    check_config_type,
    check_config_value,
    check_joint_names,
    check_manifest,
    check_weights,
)
from platypose.lifting.prior.features import FEATURES_PER_FRAME, Normalizer
from platypose.lifting.prior.pieces import (
    MAX_CHECKPOINT_BYTES,
    PIECES_FORMAT,
    is_pieces_index,
    join_pieces,
    listed_pieces,
)
from platypose.lifting.prior.schedule import TRAIN_STEPS
from platypose.lifting.settings import PriorArchitecture
from platypose.lifting.skeleton import JOINT_NAMES

CHECKPOINT_FORMAT = "platypose-prior"
CHECKPOINT_VERSION = 1
MAX_WINDOW_FRAMES = 4096
DEFAULT_PRIOR = Path(__file__).resolve().parent / "weights" / "default.pt"
PIECE_BYTES = 16 * 2**20  # larger checkpoints are written as pieces of at most this size beside a small index


@dataclass(frozen=True)
class PriorConfig(PriorArchitecture):
    """Size and data layout of the prior network: its architecture (the fields ``train`` has as options) and the
    sizes the schedule and the features fix."""

    diffusion_steps: int = TRAIN_STEPS
    features: int = FEATURES_PER_FRAME

    def __post_init__(self) -> None:
        for name in CONFIG_BOUNDS:  # types first: a checkpoint's config may hold anything
            check_config_type(name, getattr(self, name))
        for name in ("layers", "width", "heads", "ff_width", "max_frames", "diffusion_steps", "features"):
            if getattr(self, name) < 1:
                raise ValueError(f"{name} must be at least 1, got {getattr(self, name)}")
        if self.max_frames > MAX_WINDOW_FRAMES:
            raise ValueError(f"max_frames must be at most {MAX_WINDOW_FRAMES}, got {self.max_frames}")
        if self.width % self.heads or self.width % 2:
            raise ValueError(f"width {self.width} must be even and a multiple of heads ({self.heads})")
        if not (math.isfinite(self.fps) and self.fps > 0):
            raise ValueError(f"fps must be a positive number, got {self.fps}")
        if not 0 <= self.dropout < 1:
            raise ValueError(f"dropout must be in [0, 1), got {self.dropout}")
        for name in CONFIG_BOUNDS:  # a checkpoint's config decides memory and work: upper bounds
            check_config_value(name, getattr(self, name))


def sinusoidal_embedding(positions: torch.Tensor, width: int) -> torch.Tensor:
    """Transformer sinusoidal embedding of integer positions ``(...,) -> (..., width)``."""
    half = width // 2
    freqs = torch.exp(-math.log(10000.0) * torch.arange(half, device=positions.device, dtype=torch.float32) / half)
    angles = positions.to(torch.float32)[..., None] * freqs
    return torch.cat([torch.sin(angles), torch.cos(angles)], dim=-1)


class MotionPrior(nn.Module):
    """Denoiser ``G(x_t, t) -> x0`` over normalised motion windows ``(B, F, D)``."""

    def __init__(self, config: PriorConfig) -> None:
        super().__init__()
        self.config = config
        w = config.width
        self.input = nn.Linear(config.features, w)
        self.step_mlp = nn.Sequential(nn.Linear(w, w), nn.SiLU(), nn.Linear(w, w))
        layer = nn.TransformerEncoderLayer(
            d_model=w,
            nhead=config.heads,
            dim_feedforward=config.ff_width,
            dropout=config.dropout,
            activation="gelu",
            batch_first=True,
            norm_first=True,
        )
        self.encoder = nn.TransformerEncoder(layer, num_layers=config.layers, enable_nested_tensor=False)
        self.norm = nn.LayerNorm(w)
        self.output = nn.Linear(w, config.features)
        positions = sinusoidal_embedding(torch.arange(config.max_frames + 1), w)
        self.register_buffer("positions", positions, persistent=False)

    def forward(self, x_t: torch.Tensor, t: torch.Tensor) -> torch.Tensor:
        """Predict clean windows ``(B, F, D)`` from noisy ones ``(B, F, D)`` at steps ``t`` ``(B,)`` or scalar."""
        batch, frames, _ = x_t.shape
        if frames > self.config.max_frames:
            raise ValueError(f"window of {frames} frames exceeds the prior's maximum {self.config.max_frames}")
        t = torch.as_tensor(t, device=x_t.device).expand(batch)
        step_token = self.step_mlp(sinusoidal_embedding(t, self.config.width).to(x_t.dtype))[:, None, :]
        tokens = torch.cat([step_token, self.input(x_t)], dim=1) + self.positions[: frames + 1].to(x_t.dtype)
        fused = not (self.training or torch.is_grad_enabled()) and torch.backends.mha.get_fastpath_enabled()
        fused = fused and tokens.dtype == torch.float32  # bfloat16: torch's own layer kernel is faster on CPU
        hidden = self.norm(encode_for_inference(self.encoder, tokens) if fused else self.encoder(tokens))
        return self.output(hidden[:, 1:])


def encode_for_inference(encoder: nn.TransformerEncoder, tokens: torch.Tensor) -> torch.Tensor:
    """The pre-norm GELU encoder's layers on ``tokens`` ``(B, L, d)`` without autograd or dropout, as plain matrix
    products over all B*L tokens and ``scaled_dot_product_attention`` reading the heads in place.

    Equals ``encoder(tokens)`` in eval mode up to float rounding. :meth:`MotionPrior.forward` uses it in
    float32 only, where it is faster on a CPU than torch's fused encoder-layer kernel; in bfloat16 torch's
    kernel is faster and is kept (docs/results.md, 2026-12-01).
    """
    batch, length, width = tokens.shape
    x = tokens.reshape(batch * length, width)
    for layer in encoder.layers:
        attention = layer.self_attn
        heads = attention.num_heads
        h = nn.functional.layer_norm(x, (width,), layer.norm1.weight, layer.norm1.bias, layer.norm1.eps)
        qkv = torch.addmm(attention.in_proj_bias, h, attention.in_proj_weight.T)
        q, k, v = qkv.view(batch, length, 3, heads, width // heads).permute(
            2, 0, 3, 1, 4
        )  # each (B, heads, L, d/heads)
        mixed = nn.functional.scaled_dot_product_attention(q, k, v).transpose(1, 2).reshape(batch * length, width)
        x = torch.addmm(x, mixed, attention.out_proj.weight.T).add_(attention.out_proj.bias)
        h = nn.functional.layer_norm(x, (width,), layer.norm2.weight, layer.norm2.bias, layer.norm2.eps)
        h = nn.functional.gelu(torch.addmm(layer.linear1.bias, h, layer.linear1.weight.T))
        x = torch.addmm(x, h, layer.linear2.weight.T).add_(layer.linear2.bias)
    return x.view(batch, length, width)


@dataclass
class PriorBundle:
    """A loaded prior: network, normalisation, manifest and the file's checksum."""

    model: MotionPrior
    normalizer: Normalizer
    manifest: dict = field(default_factory=dict)
    checksum: str = ""

    @property
    def config(self) -> PriorConfig:
        """The network's config."""
        return self.model.config

    @property
    def device(self) -> torch.device:
        """Device of the network's weights (inputs to the sampler are put there)."""
        return next(self.model.parameters()).device

    @property
    def fps(self) -> float:
        """Frame rate the prior runs at."""
        return self.model.config.fps

    def temperature_for(self, frames: int) -> float:
        """The calibrated one-view temperature for windows of ``frames`` frames (manifest ``temperature``, fitted
        per window length by ``platypose calibrate-prior``): linear in log frames between the fitted lengths,
        the nearest one's outside them; 1 for a prior never calibrated."""
        fitted = self.manifest.get("temperature", {}).get("by_frames", {})
        if not fitted:
            return 1.0
        lengths = sorted(fitted, key=int)
        x = np.log([int(f) for f in lengths])
        return float(np.interp(np.log(frames), x, [fitted[f] for f in lengths]))

    @property
    def fixed_steps(self) -> np.ndarray | None:
        """The diffusion steps a distilled prior was trained to be called at, noisiest first (None: any steps)."""
        steps = self.manifest.get("sampling_steps")
        return None if steps is None else np.asarray(steps, dtype=np.int64)


def save_prior(path: str | Path, bundle: PriorBundle, extra: dict | None = None, piece_bytes: int = PIECE_BYTES) -> str:
    """Write a checkpoint atomically, in pieces of at most ``piece_bytes`` when larger
    (:func:`write_checkpoint_bytes`); returns its sha256. ``extra`` holds e.g. optimiser state for resuming."""
    payload = {
        "format": CHECKPOINT_FORMAT,
        "version": CHECKPOINT_VERSION,
        "config": asdict(bundle.config),
        "joint_names": list(JOINT_NAMES),
        "normalizer": {"mean": bundle.normalizer.mean.tolist(), "std": bundle.normalizer.std.tolist()},
        "manifest": json.loads(json.dumps(bundle.manifest)),  # plain Python types only (strict loading)
        "state_dict": bundle.model.state_dict(),
        "extra": extra or {},
    }
    buffer = io.BytesIO()
    torch.save(payload, buffer)
    return write_checkpoint_bytes(Path(path), buffer.getvalue(), piece_bytes)


def piece_names(path: Path) -> re.Pattern:
    """The names :func:`write_checkpoint_bytes` gives the pieces of a checkpoint at ``path``: ``NAME.SHA12.NNN``."""
    return re.compile(re.escape(path.name) + r"\.[0-9a-f]{12}\.[0-9]{3,}")


def write_checkpoint_bytes(path: Path, data: bytes, piece_bytes: int = PIECE_BYTES) -> str:
    """Write checkpoint bytes at ``path``: one file, or, over ``piece_bytes``, pieces ``NAME.SHA12.001, ...``
    beside it and at ``path`` the JSON index naming each piece's size and sha256. Each file is written
    atomically and the index last, so a checkpoint already there stays loadable until the new one is complete;
    the pieces the earlier index listed (of the names written here, :func:`piece_names`) are then removed, and no
    other file. Returns the checkpoint's sha256 (that of the joined bytes)."""
    checksum = hashlib.sha256(data).hexdigest()
    earlier = listed_pieces(path, piece_names(path))
    if len(data) <= piece_bytes:
        with atomic_open(path, "wb") as stream:
            stream.write(data)
    else:
        pieces = []
        for number, start in enumerate(range(0, len(data), piece_bytes), start=1):
            chunk = data[start : start + piece_bytes]
            name = f"{path.name}.{checksum[:12]}.{number:03d}"
            with atomic_open(path.parent / name, "wb") as stream:
                stream.write(chunk)
            pieces.append({"file": name, "bytes": len(chunk), "sha256": hashlib.sha256(chunk).hexdigest()})
        index = {"format": PIECES_FORMAT, "version": 1, "bytes": len(data), "sha256": checksum, "pieces": pieces}
        with atomic_open(path, "w") as stream:
            json.dump(index, stream, indent=1)
        earlier -= {path.parent / p["file"] for p in pieces}
    for stale in earlier:
        stale.unlink(missing_ok=True)
    return checksum


def read_checkpoint_bytes(path: Path) -> bytes:
    """The bytes of the checkpoint at ``path`` (a regular file of at most ``MAX_CHECKPOINT_BYTES``): the file
    itself, or the pieces its index names, checked before and as they are read
    (:func:`lifting.prior.pieces.join_pieces`)."""
    data = read_regular(path, MAX_CHECKPOINT_BYTES, "prior checkpoint")
    return join_pieces(path, data) if is_pieces_index(data[:256]) else data


def _check_finite(path: Path, model: MotionPrior, normalizer: Normalizer) -> None:
    """InputError naming the first non-finite weight tensor (a diverged training run) or normaliser statistic."""
    for name, tensor in model.state_dict().items():
        if not torch.isfinite(tensor).all():
            raise InputError(f"{path}: prior weights '{name}' hold NaN or infinite values (a diverged training run)")
    if not (np.isfinite(normalizer.mean).all() and np.isfinite(normalizer.std).all() and (normalizer.std > 0).all()):
        raise InputError(f"{path}: prior normalisation holds NaN, infinite or non-positive values")


def _weight_shapes(config: PriorConfig) -> dict[str, tuple[int, ...]]:
    """The weights' names and shapes of the network ``config`` describes, without allocating them."""
    with torch.device("meta"):
        return {name: tuple(value.shape) for name, value in MotionPrior(config).state_dict().items()}


def load_prior(path: str | Path | None = None, device: str | torch.device = "cpu") -> tuple[PriorBundle, dict]:
    """Load a checkpoint strictly (default: the shipped prior); returns the bundle and the ``extra`` dict.

    Raises InputError for a file that is missing, not a torch file, or not a platypose prior.
    """
    path = Path(path) if path is not None else DEFAULT_PRIOR
    if not path.is_file():
        raise InputError(f"{path}: prior checkpoint not found")
    data = read_checkpoint_bytes(path)
    try:
        payload = torch.load(io.BytesIO(data), map_location=device, weights_only=True)
    except Exception as err:  # torch raises many types for a file that is not a checkpoint
        raise InputError(f"{path}: not a platypose prior checkpoint ({type(err).__name__})") from None
    if not isinstance(payload, dict) or payload.get("format") != CHECKPOINT_FORMAT:
        raise InputError(f"{path}: not a platypose prior checkpoint (no '{CHECKPOINT_FORMAT}' header)")
    if payload.get("version") != CHECKPOINT_VERSION:
        raise InputError(f"{path}: prior checkpoint version {payload.get('version')} is not supported")
    try:
        check_joint_names(payload.get("joint_names"), list(JOINT_NAMES))
        config = PriorConfig(**check_config(payload["config"]))
        check_weights(_weight_shapes(config), payload["state_dict"])
        model = MotionPrior(config).to(device)
        model.load_state_dict(payload["state_dict"], strict=True)
        normalizer = Normalizer(
            mean=np.asarray(payload["normalizer"]["mean"], dtype=np.float64),
            std=np.asarray(payload["normalizer"]["std"], dtype=np.float64),
        )
    except (TypeError, ValueError, KeyError, RuntimeError) as err:
        detail = f"no {err}" if isinstance(err, KeyError) else str(err)  # the problem, not Python's name for it
        raise InputError(f"{path}: not a valid platypose prior ({detail})".replace("\n", " ")) from None
    _check_finite(path, model, normalizer)
    if normalizer.mean.shape != (config.features,) or normalizer.std.shape != (config.features,):
        raise InputError(f"{path}: prior normalisation does not have {config.features} values per statistic")
    manifest = check_manifest(path, payload.get("manifest", {}), config.diffusion_steps)
    model.eval()
    bundle = PriorBundle(model, normalizer, manifest, hashlib.sha256(data).hexdigest())
    return bundle, payload.get("extra", {})
