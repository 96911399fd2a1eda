"""Shared test fixtures: paths to the real data bundled in the repository."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

REPO = Path(__file__).resolve().parents[1]
DATA = REPO / "data"


@pytest.fixture(scope="session")
def data_dir() -> Path:
    """The repository's bundled real data (motion, videos, calibration, keypoints)."""
    return DATA


@pytest.fixture(scope="session")
def real_clips(data_dir: Path):
    """Real full-body clips (holosoma climbing, DeepMimic) on our skeleton."""
    from platypose.lifting.motion_io import load_motion_paths

    return load_motion_paths([data_dir / "motion" / "holosoma-climb", data_dir / "motion" / "deepmimic"])


@pytest.fixture(scope="session")
def tiny_prior(real_clips, tmp_path_factory):
    """A small prior trained in seconds on real clips (16-frame windows, 30 fps)."""
    import torch

    from platypose.lifting.offline.training import train_prior
    from platypose.lifting.prior.model import PriorConfig, load_prior
    from platypose.lifting.settings import TrainConfig

    path = tmp_path_factory.mktemp("prior") / "tiny.pt"
    torch.manual_seed(0)
    torch.set_num_threads(1)  # small batches: one thread is faster, and far faster on a busy machine
    config = PriorConfig(layers=2, width=64, heads=4, ff_width=128, max_frames=16, dropout=0.0)
    train_prior(
        real_clips,
        str(path),
        config,
        TrainConfig(iterations=300, batch_size=32, checkpoint_every=300, validate_every=300, learning_rate=1e-3),
    )
    return load_prior(path)[0]


@pytest.fixture(scope="session")
def prior_file(tiny_prior, tmp_path_factory) -> str:
    """The session's tiny prior saved as a checkpoint file for ``--prior``."""
    from platypose.lifting.prior.model import save_prior

    path = tmp_path_factory.mktemp("prior_file") / "tiny.pt"
    save_prior(path, tiny_prior)
    return str(path)


@pytest.fixture(scope="session")
def heldout_window(real_clips):
    """A 16-frame, 30 fps window of real walking (DeepMimic), pelvis centred near (0, 0, 1) m."""
    from platypose.lifting.timebase import resample

    walk = next(m for m in real_clips if "walk" in m.name)
    joints = resample(walk.joints, walk.fps, 30.0)[:16]
    return joints - joints[:, 0].mean(0) + [0.0, 0.0, 1.0]


@pytest.fixture
def run_cli(monkeypatch, capsys):
    """Run ``platypose *args`` in-process through the console entry; returns (exit code, stdout, stderr)."""
    import sys

    from platypose.cli.app import main

    def run(*args: str) -> tuple[int, str, str]:
        monkeypatch.setattr(sys, "argv", ["platypose", *map(str, args)])
        try:
            main()
            code = 0
        except SystemExit as exit_info:
            code = int(exit_info.code or 0)
        out = capsys.readouterr()
        return code, out.out, out.err

    return run


def _write_clip(path: Path, frames: list[np.ndarray], fps: float) -> None:
    import cv2

    height, width = frames[0].shape[:2]
    writer = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"mp4v"), fps, (width, height))
    for frame in frames:
        writer.write(frame)
    writer.release()


@pytest.fixture(scope="session")
def batch_folder(data_dir, tmp_path_factory) -> Path:
    """good.mp4 (the first 12 frames of cam01, halved), corrupt.mp4 (a cut-off real MP4), empty.mp4 (a blank wall)."""
    from platypose.detectors.sources.video import iter_frames

    folder = tmp_path_factory.mktemp("batch")
    frames = [
        f[::2, ::2].copy() for _, f in iter_frames(data_dir / "video/pose2sim-balancing" / "cam01.mp4", max_frames=12)
    ]
    _write_clip(folder / "good.mp4", frames, 60.0)
    _write_clip(folder / "empty.mp4", [np.full_like(frames[0], 128) for _ in frames], 60.0)
    (folder / "corrupt.mp4").write_bytes((data_dir / "video/pose2sim-balancing" / "cam02.mp4").read_bytes()[:3000])
    return folder


def pytest_collection_modifyitems(config, items) -> None:
    """The bad-input audit cases (marker ``audit``: minutes of real CLI runs) run only when asked for by ``-m``
    with an expression naming ``audit`` (``pytest -m audit tests/faults``); otherwise they are skipped, so the
    usual ``-m "not slow"`` and ``-m slow`` runs leave them out."""
    if "audit" in (config.getoption("markexpr") or ""):
        return
    skip = pytest.mark.skip(reason="audit case: run with pytest -m audit")
    for item in items:
        if item.get_closest_marker("audit") is not None:
            item.add_marker(skip)
