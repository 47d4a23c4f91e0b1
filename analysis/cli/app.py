"""The ``twopose-analyze`` application: the Typer app, its group options, and what
several commands share (options, the skipped-inputs and note lines)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from twopose.version import VersionOption

# Everything heavy (numpy, rich, mcap, pandas, matplotlib) is imported inside the command
# that needs it, so that `twopose-analyze --help` starts fast.

__all__ = ["IncludeWarnedOption", "JunitOption", "app", "note", "say_skipped"]

app = typer.Typer(
    name="twopose-analyze",
    help="Replay twopose sessions through detection and solvers into error tables and reports.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # click's plain help: wrapped at words, never boxed and cut
)


@app.callback()
def _group(version: VersionOption = False) -> None:
    """Analyse twopose sessions."""


def say_skipped(skipped: list[str]) -> None:
    if skipped:
        typer.secho(
            f"skipped {len(skipped)} results file(s) of an earlier twopose-analyze run (not "
            f"sessions): {', '.join(skipped)}",
            err=True,
            fg=typer.colors.YELLOW,
        )


def note(text: str) -> None:
    typer.secho(f"note: {text}", err=True)


JunitOption = Annotated[
    Path | None,
    typer.Option(
        "--junit",
        help="Also write JUnit XML here: one test case per session and method.",
        metavar="FILE",
    ),
]


IncludeWarnedOption = Annotated[
    bool,
    typer.Option(
        "--include-warned",
        help="Summarize over every ok trial, also those with a near-degeneracy warning "
        "(default: those are counted in n_warned and left out).",
    ),
]
