"""Exporters: npz (source of truth), CSV, BVH and rerun recordings.

``export(result, out_dir, name, formats, ...)`` is the one entry point; rerun is
imported only when a recording is written.
"""

from platypose.exporters.export import FORMATS, export
from platypose.exporters.result import LiftResult

__all__ = ["FORMATS", "LiftResult", "export"]
