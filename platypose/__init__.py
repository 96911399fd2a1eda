"""platypose: calibrated, multi-hypothesis 3D human motion from videos.

The installed package holds the repository's top-level folders under one name:
``platypose.detectors`` (2D keypoints), ``platypose.lifting`` (prior, sampler,
cameras), ``platypose.exporters`` (npz, CSV, BVH, rerun), ``platypose.cli`` (the
``platypose`` command) and ``platypose.data`` (the bundled demo takes).

The Python API (docs/api.md): ``platypose.lift(...)``, ``platypose.load_result(path)``,
``platypose.Prior.load(path=None)`` and the settings classes ``SamplerConfig``,
``WindowSettings``; imported on first use, so ``import platypose`` (and the command's
``--help``) does not load torch.
"""

from importlib.metadata import PackageNotFoundError, version

try:
    __version__ = version("platypose")
except PackageNotFoundError:  # a source tree that was not installed
    __version__ = "0.0.0+unknown"

_API = {
    "lift": "platypose.api",
    "load_result": "platypose.api",
    "Prior": "platypose.api",
    "LiftResult": "platypose.exporters.result",
    "SamplerConfig": "platypose.lifting.settings",
    "WindowSettings": "platypose.lifting.settings",
    "InputError": "platypose.lifting.errors",
}
__all__ = ["__version__", *_API]


def __getattr__(name: str):
    """The API's names, imported when first asked for."""
    if name not in _API:
        raise AttributeError(f"module 'platypose' has no attribute {name!r}")
    import importlib

    value = getattr(importlib.import_module(_API[name]), name)
    globals()[name] = value
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(_API))
