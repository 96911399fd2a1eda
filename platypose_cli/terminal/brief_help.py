"""A command whose ``--help`` shows only the options most people use, and ``--help-all`` every option in its panels.

``app.command("lift", cls=brief_help({"cams", "out", ...}))(lift)``, ``lift`` with a parameter ``help_all: bool = help_all_option()``:
the named parameters (their Python names) are shown by ``--help``, the others are hidden there and still work;
``--help-all`` shows them all. The short help ends by naming ``--help-all``.
"""

from __future__ import annotations

from collections.abc import Iterable

import typer
from typer.core import TyperCommand

MORE = "More options (detection, people, sampler, Ray, ...): --help-all."


def _show_all(ctx: typer.Context, value: bool) -> None:
    """``--help-all``: print the help with every option, then exit."""
    if not value or ctx.resilient_parsing:
        return
    ctx.meta["help_all"] = True
    typer.echo(ctx.get_help(), color=ctx.color)
    raise typer.Exit()


def help_all_option():
    """The ``--help-all`` option (eager, like ``--help``; the command receives False)."""
    return typer.Option(
        False, "--help-all", is_eager=True, expose_value=False, callback=_show_all, help="Every option, in panels."
    )


def brief_help(shown: Iterable[str]) -> type[TyperCommand]:
    """A command class whose ``--help`` shows the parameters named in ``shown`` (and ``--help-all``)."""
    names = frozenset(shown) | {"help_all"}

    class BriefHelpCommand(TyperCommand):
        def format_help(self, ctx, formatter) -> None:
            everything = ctx.meta.get("help_all", False)
            hidden = [] if everything else [p for p in self.params if p.name not in names and not p.hidden]
            self.epilog = None if everything else MORE
            for param in hidden:
                param.hidden = True
            try:
                super().format_help(ctx, formatter)
            finally:
                for param in hidden:
                    param.hidden = False

    return BriefHelpCommand
