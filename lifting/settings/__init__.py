"""Every settings class of the library, with each field's help beside it, checked once (no torch, numpy or cv2).

By job: :mod:`~platypose.lifting.settings.fields` (a field with its help, the checks every class makes), :mod:`~platypose.lifting.settings.lift` (the sampler, the
windows, the prior to load, how a take is lifted), :mod:`~platypose.lifting.settings.detection` (how a view's 2D is read or detected),
:mod:`~platypose.lifting.settings.training` (the prior's architecture, training, distillation). Every class is importable from here.
"""

from platypose.lifting.settings.detection import DetectOptions
from platypose.lifting.settings.fields import check_types, option_fields, require, setting
from platypose.lifting.settings.lift import (
    DEVICES,
    ROBUST_LOSSES,
    ROOT_MODES,
    RUNTIMES,
    PriorSettings,
    SamplerConfig,
    TakeSettings,
    WindowSettings,
)
from platypose.lifting.settings.training import DistilConfig, PriorArchitecture, TrainConfig

__all__ = [
    "DEVICES",
    "ROBUST_LOSSES",
    "ROOT_MODES",
    "RUNTIMES",
    "DetectOptions",
    "DistilConfig",
    "PriorArchitecture",
    "PriorSettings",
    "SamplerConfig",
    "TakeSettings",
    "TrainConfig",
    "WindowSettings",
    "check_types",
    "option_fields",
    "require",
    "setting",
]
