"""Named sets of motion files that training never sees, read from a JSON file (``data/motion/unseen.json``).

The file maps a set's name to glob patterns relative to the file's own folder, e.g.
``{"folders": ["kineticstoolkit-tennis", ...], "broad": ["cmu-amc/02_*", "mocapbank"]}``; a pattern naming a
folder means every motion file under it. ``platypose train --hold-out FILE`` drops every file of every set from
its data, and ``platypose eval --sets FILE`` evaluates each set on its own.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from pathlib import Path

from platypose.lifting.errors import InputError
from platypose.lifting.motion_io import motion_files


def load_sets(path: str | Path) -> dict[str, list[Path]]:
    """Every set of the file ``path`` as its sorted motion files; InputError for a bad file or a pattern that
    matches no motion file."""
    path = Path(path)
    try:
        spec = json.loads(path.read_text())
    except (OSError, UnicodeDecodeError, json.JSONDecodeError) as err:
        raise InputError(f"{path}: not a readable JSON file of unseen sets ({type(err).__name__})") from None
    if (
        not isinstance(spec, dict)
        or not spec
        or not all(isinstance(v, list) and v and all(isinstance(p, str) for p in v) for v in spec.values())
    ):
        raise InputError(f"{path}: must map each set's name to a non-empty list of glob patterns")
    sets = {}
    for name, patterns in spec.items():
        files: set[Path] = set()
        for pattern in patterns:
            matched = motion_files(sorted(path.parent.glob(pattern)))
            if not matched:
                raise InputError(f"{path}: set '{name}': pattern '{pattern}' matches no motion file")
            files.update(p.resolve() for p in matched)
        sets[name] = sorted(files)
    return sets


def without_sets(paths: Iterable[str | Path], sets: dict[str, list[Path]]) -> list[Path]:
    """The motion files of ``paths`` (files and folders) less every file of ``sets``, in loading order."""
    held = {p for files in sets.values() for p in files}
    return [p for p in motion_files(map(Path, paths)) if p.resolve() not in held]
