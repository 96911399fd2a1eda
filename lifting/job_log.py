"""The log of one lift: timestamped lines, and the warnings and notes its result's meta keeps."""

from __future__ import annotations

import time
from pathlib import Path


class JobLog:
    """Timestamped lines of one lift (``OUT/<name>/log.txt`` for the CLI), and its warnings and notes for the result's
    meta."""

    def __init__(self) -> None:
        self.started = time.perf_counter()
        self.lines: list[str] = []
        self.warnings: list[str] = []
        self.notes: list[str] = []

    def __call__(self, message: str) -> None:
        self.lines.append(f"[{time.perf_counter() - self.started:7.1f} s] {message}")

    def warning(self, message: str) -> None:
        """Log a warning and keep it for the result's meta."""
        self.warnings.append(message)
        self(f"warning: {message}")

    def note(self, message: str) -> None:
        """Log what the lift assumed (not a fault: no warning) and keep it for the result's ``meta["notes"]``."""
        self.notes.append(message)
        self(message)

    def write(self, path: Path) -> None:
        """Write the log atomically."""
        from platypose.lifting.files.atomic import write_text_atomic

        write_text_atomic(path, "\n".join(self.lines) + "\n")
