"""``platypose version``-like small commands that need no heavy imports."""

from __future__ import annotations

import platform

import typer

from platypose import __version__


def doctor() -> None:
    """Print the versions of platypose and of the libraries it runs on."""
    import cv2
    import numpy
    import onnxruntime
    import rerun
    import torch

    typer.echo(f"platypose {__version__} on Python {platform.python_version()} ({platform.machine()})")
    for name, mod in (
        ("torch", torch),
        ("numpy", numpy),
        ("opencv", cv2),
        ("onnxruntime", onnxruntime),
        ("rerun-sdk", rerun),
    ):
        typer.echo(f"  {name:12s} {mod.__version__}")
    typer.echo(f"  torch threads {torch.get_num_threads()}, cuda available: {torch.cuda.is_available()}")
