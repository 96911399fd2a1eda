"""platypose: calibrated, multi-hypothesis 3D human motion from videos.

The installed package holds the repository's top-level folders under one name:
``platypose.detectors`` (2D keypoints), ``platypose.lifting`` (prior, sampler,
cameras), ``platypose.exporters`` (npz, CSV, BVH, rerun), ``platypose.cli`` (the
``platypose`` command) and ``platypose.data`` (the bundled demo takes).
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("platypose")
except PackageNotFoundError:  # a source tree that was not installed
    __version__ = "0.0.0+unknown"
