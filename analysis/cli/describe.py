"""``twopose-analyze info``: check and describe sessions."""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from twopose.errors import (
    EXIT_SOME_INPUTS_FAILED,
    TwoposeError,
    handle_errors,
)
from twopose.text import for_terminal

if TYPE_CHECKING:
    from twopose.format.trials import SessionOverview

from analysis.cli.app import app, note, say_skipped


@app.command()
def info(
    paths: Annotated[
        list[Path], typer.Argument(help="Session files and/or folders (searched recursively).")
    ],
) -> None:
    """Check and describe sessions: method, cameras, trials, poses, captures, frames."""
    from rich.console import Console
    from rich.markup import escape
    from rich.table import Table

    from analysis.input_set import resolve_inputs
    from twopose.format.trials import describe_session

    console = Console()
    with handle_errors():
        inputs = resolve_inputs(paths)  # each session once, empty and board ones included
    say_skipped(list(inputs.skipped))
    for text in inputs.notes():
        note(text)
    order = {p: k for k, p in enumerate(inputs.files)}  # a session's parts together
    first_of = {p: f for f, later in inputs.continuations.items() for p in later}

    def place(path: str) -> tuple[int, bool]:
        return order.get(first_of.get(path) or path, len(order)), path in first_of

    sessions = sorted((s.path for s in inputs.found), key=place)
    overviews: list[SessionOverview] = []
    failed: list[tuple[str, str]] = []
    for path in sessions:
        try:
            overviews.append(describe_session(path))
        except TwoposeError as err:
            failed.append((path, str(err)))
    # A session and its continuations are one session: its parts listed under it.
    parts = {p: first for first, later in inputs.continuations.items() for p in later}
    joined = sum(1 for o in overviews if str(o.path) in parts)
    title = f"{len(overviews) - joined} session(s)"
    table = Table(title=title + (f", {joined} continued in a later file" if joined else ""))
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
            f" ({o.n_set_aside} set aside, {o.n_incomplete_captures} incomplete)"
            if o.n_set_aside or o.n_incomplete_captures
            else ""
        )
        after = o.info.continues_after_trial
        where = escape(for_terminal(str(o.path)))
        table.add_row(
            f"+ {where} (after trial {after})" if str(o.path) in parts else where,
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
    for o in overviews:
        _print_notes(o)
    for path, reason in failed:
        typer.secho(f"failed: {path}: {reason}", err=True, fg=typer.colors.RED)
    if not sessions:
        typer.secho("no session files (*.mcap) found", err=True, fg=typer.colors.YELLOW)
    if failed or not sessions:
        raise typer.Exit(EXIT_SOME_INPUTS_FAILED)


def _print_notes(o: SessionOverview) -> None:
    """The operator's notes of one session (``info``), session-wide first."""
    # A note is what someone typed, into a file anyone may hand us: escaped, so that an
    # ESC sequence or a bidi override in it is shown, not obeyed.
    lines = [f"  session: {for_terminal(text)}" for text in o.notes.session]
    lines += [
        f"  trial {trial}: {for_terminal(text)}"
        for trial, texts in sorted(o.notes.by_trial.items())
        for text in texts
    ]
    if lines:
        typer.echo(f"notes in {for_terminal(str(o.path))}:")
        typer.echo("\n".join(lines))
