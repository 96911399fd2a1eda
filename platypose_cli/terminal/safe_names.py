"""Job and view names made into file names that always stay inside ``--out``.

A name comes from a file or folder name the user gave (a video ``..mp4`` has the stem ``.``, ``...mp4`` the stem
``..``); it becomes a folder ``OUT/<name>/`` and the prefix of every file there, so it must be one plain path
component: no separators, no control or format characters (a newline would also forge console lines, U+202E
reverse them), no bytes that are not UTF-8, no leading dot (``.``, ``..`` and hidden files), not a name the batch
writes itself, and short enough for the file system.
"""

from __future__ import annotations

import re
import unicodedata
from collections.abc import Callable, Sequence

RESERVED = frozenset({"summary.json", "summary"})  # the batch's own files in OUT
MAX_BYTES = 120  # leaves room for suffixes such as ``_p12_h099.bvh`` and staging prefixes within 255 bytes
_UNSAFE = re.compile(r"[/\\:*?\"<>|]")
# What a console line must not show raw: controls (C0, C1), format characters (U+202E right-to-left override,
# zero-width ones), line and paragraph separators (U+2028, U+2029), surrogates (file names that are not UTF-8).
_HIDDEN = frozenset({"Cc", "Cf", "Cs", "Zl", "Zp"})


def safe_name(name: str) -> str:
    """``name`` as one safe path component (unchanged when it already is one): unsafe characters become ``_``,
    leading dots become ``_``, reserved names get a ``_take`` suffix, long names are cut at a character boundary."""
    cleaned = _UNSAFE.sub("_", _shown(name, "_")).strip(" ")
    stripped = cleaned.lstrip(".")
    cleaned = "_" * (len(cleaned) - len(stripped)) + stripped
    if not cleaned:
        cleaned = "take"
    if cleaned.lower() in RESERVED:
        cleaned += "_take"
    encoded = cleaned.encode("utf-8", errors="replace")
    if len(encoded) > MAX_BYTES:
        cleaned = encoded[:MAX_BYTES].decode("utf-8", errors="ignore")
    return cleaned


def printable(text: str) -> str:
    """``text`` for one console line: control, format and separator characters (newlines, escapes, U+202E,
    U+009B, U+2028) and undecodable bytes of file names shown as ``?``."""
    return _shown(text, "?")


def _shown(text: str, mark: str) -> str:
    """``text`` with each character of a hidden category replaced by ``mark``."""
    return "".join(mark if unicodedata.category(c) in _HIDDEN else c for c in text)


def distinct_names(wanted: Sequence[str], usable: Callable[[int, str], bool] = lambda i, name: True) -> list[str]:
    """One name per wanted name, no two alike (ignoring case): the first of a wanted name keeps it if
    ``usable(index, name)``; the others get ``NAME-k``, with the smallest k whose name no one wants and is usable."""
    names: list[str | None] = [None] * len(wanted)
    taken: set[str] = set()
    for i, name in enumerate(wanted):
        if name.casefold() not in taken and usable(i, name):
            names[i] = name
            taken.add(name.casefold())
    reserved = taken | {name.casefold() for name in wanted}
    for i, name in enumerate(wanted):
        k = 2
        while names[i] is None:
            candidate = f"{name}-{k}"
            if candidate.casefold() not in reserved and usable(i, candidate):
                names[i] = candidate
                reserved.add(candidate.casefold())
            k += 1
    return names
