"""onnxruntime sessions with a chosen thread count and execution provider, checked after loading."""

from __future__ import annotations

import warnings
from pathlib import Path

from platypose.lifting.errors import InputError

CPU = "CPUExecutionProvider"


class ProviderFallbackWarning(RuntimeWarning):
    """The execution provider asked for was not the one onnxruntime used."""


def open_session(model: str | Path, threads: int | None = None, provider: str = CPU):
    """An ``onnxruntime.InferenceSession`` for ``model`` on ``provider`` (CPU fallback warns loudly).

    ``threads`` sets intra-op threads (None: onnxruntime's default, all cores).
    InputError if the file is missing, not a loadable model, or the provider is not installed.
    """
    import onnxruntime as ort

    model = Path(model)
    if not model.is_file():
        raise InputError(f"{model}: model file not found")
    available = ort.get_available_providers()
    if provider not in available:
        raise InputError(f"{model}: execution provider {provider} is not installed; available: {', '.join(available)}")
    options = ort.SessionOptions()
    if threads is not None:
        if threads < 1:
            raise InputError(f"{model}: threads must be at least 1, got {threads}", option="threads")
        options.intra_op_num_threads = threads
        options.inter_op_num_threads = 1
    options.log_severity_level = 3
    providers = [provider] if provider == CPU else [provider, CPU]
    try:
        session = ort.InferenceSession(str(model), options, providers=providers)
    except Exception as err:  # onnxruntime raises its own exception types for any bad model
        message = str(err).splitlines()[0] if str(err) else type(err).__name__
        raise InputError(f"{model}: onnxruntime cannot load it ({message})") from None
    used = session.get_providers()[0]
    if used != provider:
        warnings.warn(
            f"{model}: asked for {provider} but onnxruntime runs on {used}; detection will be slow",
            ProviderFallbackWarning,
            stacklevel=2,
        )
    return session
