"""Bundled real data, installed as ``platypose.data``: the demo takes (videos, calibration, 2D keypoints).

Provenance and licences: PROVENANCE.md here and a licence file beside each take. The motion
capture under ``motion/`` (training data) stays in the repository and is not installed.
"""

from pathlib import Path

DATA_DIR = Path(__file__).resolve().parent
VIDEO_DIR = DATA_DIR / "video"
