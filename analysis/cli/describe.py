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
from twopose.values.bounds import shown
from twopose.values.text import for_terminal

if TYPE_CHECKING:
    from analysis.batch.inputs import InputSet
    from twopose.format.trials import SessionOverview

from analysis.cli.app import app, note, say_skipped

#: From this many columns on, ``info`` gives the cameras and the format columns of their own.
_WIDE = 110


@app.command()
def info(
    paths: Annotated[
        list[Path], typer.Argument(help="Session files and/or folders (searched recursively).")
    ],
) -> None:
    """Check and describe sessions: method, cameras, trials, poses, captures, frames."""
    from rich import box
    from rich.console import Console
    from rich.table import Table

    from analysis.batch.inputs import resolve_inputs, sessions_said
    from twopose.format.trials import describe_session

    console = Console()
    with handle_errors():
        inputs = resolve_inputs(paths)  # each session once, empty and board ones included
    say_skipped(list(inputs.skipped))
    for text in inputs.notes():
        note(text)
    # A session's parts together, in trial order (its head first), then board sessions.
    names = _names(inputs)
    sessions = [*names, *(s.path for s in inputs.boards)]
    overviews: list[SessionOverview] = []
    failed: list[tuple[str, str]] = []
    for path in sessions:
        try:
            overviews.append(describe_session(path))
        except TwoposeError as err:
            failed.append((path, str(err)))
    joined = sum(1 for o in overviews if names.get(str(o.path), "").startswith("+ "))
    described = {str(o.path) for o in overviews}
    title = sessions_said(
        [(st.session_id, st.branch) for st in inputs.strands if st.head in described]
        + [(b.session_id, "") for b in inputs.boards if b.path in described]
    )
    # At a narrow terminal (80 columns, a pipe) the cameras and the format go under the
    # session's label, so that the label (the shortest tail of its path no other input
    # shares: what tells two rows apart) keeps its width and folds, never cut.
    narrow = console.width < _WIDE
    columns = ["method", "units", "trials", "poses", "captures", "frames"]
    if not narrow:
        columns[2:2] = ["cameras"]
        columns.append("format")
    table = Table(
        title=title + (f", {joined} continued in a later file" if joined else ""),
        box=box.SIMPLE_HEAD if narrow else box.HEAVY_HEAD,
        pad_edge=not narrow,
    )
    # The label keeps room for a file name (a long captures cell wraps instead of
    # squeezing it to a letter a line).
    table.add_column("session", overflow="fold", ratio=1, min_width=_LABEL_MIN)
    for col in columns:
        wraps = narrow and col == "captures"  # "2 (1 set aside, 0 incomplete)" on lines
        table.add_column(
            col, overflow="fold", no_wrap=narrow and not wraps, max_width=14 if wraps else None
        )
    for o in overviews:
        path = str(o.path)
        table.add_row(
            *_row(o, names.get(path, inputs.labels.get(path, path)), columns, narrow=narrow)
        )
    console.print(table)
    for o in overviews:
        _print_notes(o)
        _print_pair(o)
    for path, reason in failed:
        said = reason if reason.startswith(path) else f"{path}: {reason}"
        typer.secho(f"failed: {said}", err=True, fg=typer.colors.RED)
    if not sessions:
        typer.secho("no session files (*.mcap) found", err=True, fg=typer.colors.YELLOW)
    if failed or not sessions:
        raise typer.Exit(EXIT_SOME_INPUTS_FAILED)


#: The session column's least width at a narrow terminal (characters).
_LABEL_MIN = 18


def _names(inputs: InputSet) -> dict[str, str]:
    """Each measurement session's part, in trial order, by the name ``info`` shows: its
    label, a later part marked ``+ ... (after trial N)``, a branch ``[branch B]``."""
    labels = inputs.labels
    names: dict[str, str] = {}
    for strand in inputs.strands:
        for k, part in enumerate(strand.parts):
            path = part.file.path
            name = labels.get(path, path)
            if k:
                name = f"+ {name} (after trial {part.file.continues_after})"
            names[path] = name + (f" [branch {part.branch}]" if part.branch else "")
    return names


def _row(o: SessionOverview, name: str, columns: list[str], *, narrow: bool) -> list[str]:
    """One session's cells: its name (escaped: a file name is anyone's text), then
    ``columns``; at a narrow terminal the cameras and format under the name."""
    from rich.markup import escape

    cams = ", ".join(f"{c.camera_id} f={shown(c.intrinsics.fx)}" for c in o.cameras)
    captures = f"{o.n_captures}" + (
        f" ({o.n_set_aside} set aside, {o.n_incomplete_captures} incomplete)"
        if o.n_set_aside or o.n_incomplete_captures
        else ""
    )
    if o.streams is not None:  # stream trials: no pose typed, no capture (its windows are not)
        captures = "-"
    sim = " (sim)" if o.info.simulated else ""
    where = escape(for_terminal(name))
    if narrow:
        where += f"\n[dim]{escape(cams)}, format {o.format_version}{sim}[/dim]"
    cells = {
        "method": o.info.method + ("" if narrow else sim),
        "units": o.info.units,
        "cameras": cams,
        "trials": str(o.n_trials),
        "poses": "-" if o.streams is not None else str(o.n_poses),
        "captures": captures,
        "frames": str(o.n_frames),
        "format": o.format_version,
    }
    return [where, *(cells[c] for c in columns)]


def _print_pair(o: SessionOverview) -> None:
    """A two-camera session's pair, clock offset and touches (``info``); nothing for a
    one-camera session."""
    if o.streams is None:
        return
    from analysis.session.stream_tables import pair_lines

    for line in pair_lines(o.streams):
        typer.echo(for_terminal(line))


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
