"""The plan of a split lift's pieces: the SHA-256 of each piece file the driver saw finished, kept in
``OUT/<name>/.pieces/plan.json`` (written atomically as each piece finishes). A later run trusts a piece file only
when the plan holds its digest: a piece damaged, truncated or changed since it was written, or one the plan never
listed (a run killed between the piece's rename and the plan's write), is redone, not read.
"""

from __future__ import annotations

import hashlib
import json
import os
import stat
from pathlib import Path

from platypose.lifting.files.atomic import write_text_atomic
from platypose.lifting.files.reads import json_value, read_regular

PLAN = "plan.json"
MAX_PLAN_BYTES = 2**24  # a few hundred bytes per piece


def file_digest(path: Path) -> str:
    """The SHA-256 of the file ``path``, read in chunks."""
    h = hashlib.sha256()
    with open(path, "rb") as stream:
        while chunk := stream.read(2**20):
            h.update(chunk)
    return h.hexdigest()


class PiecePlan:
    """The digests of the finished pieces in the piece folder ``folder`` (an unreadable plan holds none: every
    piece is then redone)."""

    def __init__(self, folder: Path) -> None:
        self.path = folder / PLAN
        self.digests = self._read()

    def _read(self) -> dict[str, str]:
        try:
            content = json_value(read_regular(self.path, MAX_PLAN_BYTES, "plan of pieces"))
        except (OSError, ValueError):  # missing or damaged (InputError, UnicodeDecodeError): nothing trusted
            return {}
        pieces = content.get("pieces") if isinstance(content, dict) else None
        if not isinstance(pieces, dict):
            return {}
        return {k: v for k, v in pieces.items() if isinstance(k, str) and isinstance(v, str)}

    def why_not(self, path: Path) -> str | None:
        """None when ``path`` is a regular file whose digest the plan holds; else why it is not to be trusted."""
        mode = os.lstat(path).st_mode
        if not stat.S_ISREG(mode):
            return "not a regular file"
        if path.name not in self.digests:
            return "not in the plan of finished pieces (its run stopped before recording it)"
        if file_digest(path) != self.digests[path.name]:
            return "changed since it was written (its SHA-256 differs from the plan's)"
        return None

    def record(self, path: Path) -> None:
        """Keep the digest of the finished piece ``path``, and write the plan."""
        self.digests[path.name] = file_digest(path)
        self._write()

    def forget(self, path: Path) -> None:
        """Drop ``path`` from the plan (it is being redone), and write the plan."""
        if self.digests.pop(path.name, None) is not None:
            self._write()

    def _write(self) -> None:
        write_text_atomic(self.path, json.dumps({"pieces": self.digests}, indent=1, sort_keys=True))
