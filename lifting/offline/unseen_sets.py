"""Named sets of motion files that training never sees, read from a JSON file (``data/motion/unseen.json``).

The file maps a set's name to glob patterns relative to the file's own folder, e.g.
``{"folders": ["kineticstoolkit-tennis", ...], "broad": ["cmu-amc/02_*", "mocapbank"]}``; a pattern naming a
folder means every motion file under it. ``platypose train --hold-out FILE`` drops every file of every set from
its data, and ``platypose eval --sets FILE`` evaluates each set on its own.

The file must be a regular file of at most ``MAX_SETS_BYTES`` (a FIFO would block the reader for ever), JSON nested
no deeper than Python can parse, and each pattern relative and not empty (``/etc/*`` or ``""`` name no set's
files); else one line naming the file, and the set and pattern.
"""

from __future__ import annotations

from collections.abc import Iterable
from pathlib import Path, PurePosixPath, PureWindowsPath

from platypose.lifting.errors import InputError
from platypose.lifting.files.reads import json_value, read_regular
from platypose.lifting.motion_io import motion_files

MAX_SETS_BYTES = 2**20  # a few sets of a few patterns each take a few hundred bytes


def pattern_problem(pattern: str) -> str | None:
    """Why ``pattern`` cannot name files relative to the sets file's folder (empty, absolute), or None."""
    if not pattern.strip():
        return "is empty"
    if PurePosixPath(pattern).is_absolute() or PureWindowsPath(pattern).anchor:
        return "is absolute; patterns are relative to the sets file's folder"
    return None


def _set_files(path: Path, name: str, patterns: list[str]) -> list[Path]:
    """The sorted motion files the ``patterns`` of set ``name`` match beside the sets file ``path``; InputError
    naming the file, the set and the pattern that is empty, absolute, not a pattern or matches no motion file."""
    files: set[Path] = set()
    for pattern in patterns:
        where = f"{path}: set '{name[:80]}': pattern '{pattern[:200]}'"
        problem = pattern_problem(pattern)
        if problem is not None:
            raise InputError(f"{where} {problem}")
        try:
            matched = motion_files(sorted(path.parent.glob(pattern)))
        except (ValueError, NotImplementedError, OSError) as err:
            raise InputError(f"{where} is not a glob pattern ({err})") from None
        if not matched:
            raise InputError(f"{where} matches no motion file")
        files.update(p.resolve() for p in matched)
    return sorted(files)


def load_sets(path: str | Path) -> dict[str, list[Path]]:
    """Every set of the file ``path`` as its sorted motion files; InputError for a file that is not a regular JSON
    file of sets (:data:`MAX_SETS_BYTES`, nested too deep) or a pattern that is empty, absolute or matches no
    motion file."""
    path = Path(path)
    text = read_regular(path, MAX_SETS_BYTES, "unseen-sets file")
    try:
        spec = json_value(text)
    except ValueError as err:
        raise InputError(f"{path}: not a readable JSON file of unseen sets ({err})") from None
    if (
        not isinstance(spec, dict)
        or not spec
        or not all(isinstance(v, list) and v and all(isinstance(p, str) for p in v) for v in spec.values())
    ):
        raise InputError(f"{path}: must map each set's name to a non-empty list of glob patterns")
    return {name: _set_files(path, name, patterns) for name, patterns in spec.items()}


def without_sets(paths: Iterable[str | Path], sets: dict[str, list[Path]]) -> list[Path]:
    """The motion files of ``paths`` (files and folders) less every file of ``sets``, in loading order."""
    held = {p for files in sets.values() for p in files}
    return [p for p in motion_files(map(Path, paths)) if p.resolve() not in held]
