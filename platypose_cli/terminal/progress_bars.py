"""Progress bars of one lift: one per group of persons lifted together, each with its length known at its first
update."""

from __future__ import annotations

import sys

import typer


class GroupBars:
    """One progress bar per group of persons lifted together, its length known at its first update."""

    def __init__(self, hidden: bool) -> None:
        self.hidden, self.group, self.bar = hidden, None, None

    def update(self, group: list[int] | str, done: int, total: int) -> None:
        if group != self.group:
            self.close()
            label = group if isinstance(group, str) else f"lifting {len(group)} person(s)"  # str: the quick lift
            self.group, self.bar = group, LazyBar(label, self.hidden)
        self.bar.update(done, total)

    def close(self) -> None:
        """Finish the current bar's line."""
        if self.bar is not None:
            self.bar.close()
            self.bar = None


class LazyBar:
    """A progress bar whose length is known only at the first ``update(done, total)``."""

    def __init__(self, label: str, hidden: bool) -> None:
        self.label, self.hidden, self.bar, self.done = label, hidden, None, 0

    def update(self, done: int, total: int) -> None:
        if self.bar is None:
            self.bar = typer.progressbar(length=total, label=self.label, file=sys.stderr, hidden=self.hidden)
            self.bar.__enter__()
        self.bar.update(done - self.done)
        self.done = done

    def close(self) -> None:
        """Finish the bar's line, if it was shown."""
        if self.bar is not None:
            self.bar.__exit__(None, None, None)
