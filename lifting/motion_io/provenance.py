"""Source and licence of a motion file, from the nearest ``SOURCE.json`` in its folder or a parent folder."""

from __future__ import annotations

import json
from pathlib import Path

from platypose.lifting.errors import InputError

SOURCE_FILE = "SOURCE.json"
UNKNOWN = "unknown"


def find_provenance(path: Path) -> tuple[str, str]:
    """``(source, licence)`` from the nearest SOURCE.json above ``path``, else ``("unknown", "unknown")``."""
    for folder in Path(path).resolve().parents:
        candidate = folder / SOURCE_FILE
        if candidate.is_file():
            try:
                info = json.loads(candidate.read_text(encoding="utf-8"))
                return str(info["source"]), str(info["licence"])
            except (ValueError, KeyError, TypeError, RecursionError) as err:
                raise InputError(f'{candidate}: expected {{"source": ..., "licence": ...}} ({err})') from None
    return UNKNOWN, UNKNOWN
