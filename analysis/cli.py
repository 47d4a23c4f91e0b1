"""``twopose-analyze``: the analyst's command line (a thin layer over the library)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer
from rich.console import Console
from rich.table import Table

from analysis.replay import SessionOverview, describe_session, find_sessions
from recorder.cli import handle_errors
from recorder.errors import EXIT_SOME_INPUTS_FAILED, TwoposeError

__all__ = ["app", "main"]

app = typer.Typer(
    name="twopose-analyze",
    help="Replay twopose sessions through detection and solvers into error tables and reports.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


@app.callback()
def _group() -> None:
    """Analyse twopose sessions."""


@app.command()
def info(
    paths: Annotated[
        list[Path], typer.Argument(help="Session files and/or folders (searched recursively).")
    ],
) -> None:
    """Check and describe sessions: method, cameras, trials, poses, captures, frames."""
    console = Console()
    with handle_errors():
        sessions = find_sessions(paths)
    overviews: list[SessionOverview] = []
    failed: list[tuple[Path, str]] = []
    for path in sessions:
        try:
            overviews.append(describe_session(path))
        except TwoposeError as err:
            failed.append((path, str(err)))
    table = Table(title=f"{len(overviews)} session(s)")
    for col in (
        "session",
        "method",
        "units",
        "cameras",
        "trials",
        "poses",
        "captures",
        "frames",
        "format",
    ):
        table.add_column(col)
    for o in overviews:
        cams = ", ".join(f"{c.camera_id} f={c.intrinsics.fx:g}" for c in o.cameras)
        captures = f"{o.n_captures}" + (
            f" ({o.n_incomplete_captures} incomplete)" if o.n_incomplete_captures else ""
        )
        table.add_row(
            str(o.path),
            o.info.method + (" (sim)" if o.info.simulated else ""),
            o.info.units,
            cams,
            str(o.n_trials),
            str(o.n_poses),
            captures,
            str(o.n_frames),
            o.format_version,
        )
    console.print(table)
    for path, reason in failed:
        typer.secho(f"failed: {path}: {reason}", err=True, fg=typer.colors.RED)
    if not sessions:
        typer.secho("no session files (*.mcap) found", err=True, fg=typer.colors.YELLOW)
    if failed or not sessions:
        raise typer.Exit(EXIT_SOME_INPUTS_FAILED)


def main() -> None:
    app()
