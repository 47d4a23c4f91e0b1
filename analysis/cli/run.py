"""``twopose-analyze run``: the main job, sessions to tables, figures and a report."""

from __future__ import annotations

import contextlib
import errno
import sys
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, cast

import typer

from twopose.errors import (
    EXIT_INTERRUPTED,
    EXIT_SOME_INPUTS_FAILED,
    InputValueError,
    end_on_closed_pipe,
    handle_errors,
    say_interrupted,
)
from twopose.solve.margins import EstimateOptions
from twopose.uncertainty.noise import NoiseModel
from twopose.values.choices import CombineRule
from twopose.values.options import read_option

if TYPE_CHECKING:
    from analysis.results import RunResult

from analysis.choices import (
    DEFAULT_SESSION_TIMEOUT_S,
    FIGURE_FORMATS,
    FigureFormat,
    RigCalibrationMode,
)
from analysis.cli.app import IncludeWarnedOption, JunitOption, app, note, say_skipped

#: The options' defaults, from their one record.
_ESTIMATE = EstimateOptions()

SessionTimeoutOption = Annotated[
    float,
    typer.Option(
        **read_option("SESSION_TIMEOUT"),
        help="Stop a session still running after this many seconds and list it as failed "
        "(0: no limit).",
    ),
]


RigFileOption = Annotated[
    Path | None,
    typer.Option(
        exists=True,
        dir_okay=False,
        help="Correct every session's views by this rig file's constants (from "
        "`twopose-analyze rig`), carry their covariance into every region, and give every "
        "region its placing sigma when the file has one [default: each session takes the "
        "nearest rig.toml up the tree from its folder: a rig.toml applies to the sessions "
        "in its folder and below].",
    ),
]
NoRigOption = Annotated[
    bool,
    typer.Option("--no-rig", help="Use no rig file, not even a rig.toml above the sessions."),
]
RigCalibrationOption = Annotated[
    RigCalibrationMode,
    typer.Option(
        help="loo: also each trial corrected by constants its session's other trials give "
        "(x_rig, y_rig, z_rig, err_rig; rig.csv).",
    ),
]


def _figure_formats(given: list[str] | None) -> list[str]:
    """``--figures``, each a format of :data:`analysis.choices.FIGURE_FORMATS` (typer takes
    no list of a Literal's choices, so they are checked here, by the one list)."""
    for fmt in given or ():
        if fmt not in FIGURE_FORMATS:
            choices = ", ".join(FIGURE_FORMATS)
            raise typer.BadParameter(f"{fmt!r} is not one of {choices}")
    return list(given or ())


FiguresOption = Annotated[
    list[str] | None,
    typer.Option(
        "--figures",
        metavar="[" + "|".join(FIGURE_FORMATS) + "]",
        callback=_figure_formats,
        help="Also write the static figures (matplotlib) in this format, for papers "
        "(--figures png; repeated for more formats: --figures png --figures pdf). Without "
        "it no figure is drawn: report.html's charts are drawn by the browser from the "
        "run's tables.",
    ),
]


ReuseOption = Annotated[
    bool,
    typer.Option(
        "--reuse/--no-reuse",
        help="Reuse each session's analysis and figures from the last run into --out where "
        "nothing they depend on changed (the session's files and identity, the options, the "
        "rig file, twopose's code); --no-reuse: analyse and draw everything afresh.",
    ),
]


JobsOption = Annotated[
    int | None,
    typer.Option(
        **read_option("JOBS"),
        help="Worker processes (results do not depend on it) [default: 1].",
    ),
]

DaskOption = Annotated[
    str | None,
    typer.Option(help="Address of an existing Dask scheduler to run the sessions on."),
]

MinParallaxOption = Annotated[
    float,
    typer.Option(
        **read_option("MARGIN_ANGLE"),
        help="Warn when a point's ray parallax is below this (deg).",
    ),
]

MinPlaneAngleOption = Annotated[
    float,
    typer.Option(
        **read_option("MARGIN_ANGLE"),
        help="Warn when back-projected planes meet below this (deg).",
    ),
]

MinGroundAngleOption = Annotated[
    float,
    typer.Option(
        **read_option("MARGIN_ANGLE"),
        help="Warn when the line meets the ground below this (deg).",
    ),
]

SceneOption = Annotated[
    bool,
    typer.Option(
        help="Also write results_<n>_<session>.mcap per session: images with the "
        "detections drawn, and each trial's 3-D geometry, for Foxglove."
    ),
]

Sigma0Option = Annotated[
    bool,
    typer.Option(
        "--sigma0/--no-sigma0",
        help="Estimate the placing error from each session's redundant trials (the "
        "placing variance's multiplier, always used, with its uncertainty; sigma0's test; "
        "the trials whose poses disagree flagged) and propagate every 95% region with it "
        "(docs/uncertainty.md); --no-sigma0: the typed or measured placing sigma as it is.",
    ),
]

CombineOption = Annotated[
    CombineRule, typer.Option(help="How a pose's frames are combined (thesis: mean).")
]


@app.command("run")
def run_command(
    paths: Annotated[list[Path], typer.Argument(help="Session files and/or folders (recursive).")],
    out: Annotated[
        Path, typer.Option("--out", help="Output folder for tables, figures, report.")
    ] = Path("results"),
    jobs: JobsOption = None,
    dask: DaskOption = None,
    combine: CombineOption = _ESTIMATE.combine,
    min_parallax: MinParallaxOption = _ESTIMATE.min_parallax_deg,
    min_plane_angle: MinPlaneAngleOption = _ESTIMATE.min_plane_angle_deg,
    min_ground_angle: MinGroundAngleOption = _ESTIMATE.min_ground_angle_deg,
    scene: SceneOption = True,
    session_timeout: SessionTimeoutOption = DEFAULT_SESSION_TIMEOUT_S,
    include_warned: IncludeWarnedOption = False,
    junit: JunitOption = None,
    rig: RigFileOption = None,
    no_rig: NoRigOption = False,
    rig_calibration: RigCalibrationOption = "none",
    sigma0: Sigma0Option = _ESTIMATE.noise.test_redundancy,
    figures: FiguresOption = None,
    reuse: ReuseOption = True,
) -> None:
    """Replay sessions through detection and solvers into error tables, figures and a report."""
    from analysis.batch.inputs import resolve_inputs
    from analysis.batch.outputs import check_run_outputs, write_file
    from analysis.batch.runner import run
    from analysis.results import AnalysisOptions
    from analysis.rig.scope import rig_scope

    options = AnalysisOptions(
        estimate=EstimateOptions(
            combine=combine,
            min_parallax_deg=min_parallax,
            min_plane_angle_deg=min_plane_angle,
            min_ground_angle_deg=min_ground_angle,
            noise=NoiseModel(test_redundancy=sigma0),
        ),
        session_timeout_s=session_timeout or None,
        include_warned=include_warned,
        rig_calibration=rig_calibration,
        figures=tuple(dict.fromkeys(cast("list[FigureFormat]", figures or ()))),  # each once
    )
    with handle_errors(), _session_progress(out) as (found, done):
        if jobs is not None and dask is not None:  # given, it would be ignored
            raise InputValueError(
                "--jobs: the Dask scheduler (--dask) runs the sessions on its own workers; "
                "leave --jobs out, or --dask"
            )
        inputs = resolve_inputs(paths)  # once: every step below takes this set
        # Each session's rig file, read and checked before anything is written.
        rigs = rig_scope(inputs, rig, no_rig=no_rig, on_note=note)
        check_run_outputs(inputs, out, junit, *rigs.paths)
        result = run(
            inputs,
            out,
            jobs=jobs or 1,
            dask_address=dask,
            options=options,
            on_session_done=done,
            on_sessions_found=found,
            scene=scene,
            reuse=reuse,
            rigs=rigs,
        )
        if junit is not None:
            from analysis.gate.baseline import junit_xml, run_cases

            cases = run_cases(result.summary, result.errors)
            notes = [*result.input_notes, *(f"skipped: {p}" for p in result.skipped)]
            write_file(junit, junit_xml("twopose-analyze run", cases, notes))
    try:
        _print_run(result, out, include_warned=include_warned)
    except KeyboardInterrupt:  # the outputs are committed: say so, not just "interrupted"
        say_interrupted(
            f"interrupted while printing the summary; the results in {out} are complete"
        )
        raise typer.Exit(EXIT_INTERRUPTED) from None
    except BrokenPipeError:  # `run ... | head -3`: the results are written; nobody reads on
        end_on_closed_pipe()


def _stdout_closed() -> bool:
    """Whether stdout is a pipe whose reader has gone (``run ... | head -1`` once ``head``
    has its line): a poll says so (POLLERR) without a write; never at a terminal or into a
    file."""
    import select

    try:
        fd = sys.stdout.fileno()
    except (AttributeError, OSError, ValueError):  # not a file (a notebook, a test runner)
        return False
    poller = select.poll()
    poller.register(fd, select.POLLOUT)
    return any(events & select.POLLERR for _, events in poller.poll(0))


@contextlib.contextmanager
def _session_progress(
    out: Path,
) -> Iterator[tuple[Callable[[int], None], Callable[[str, bool], None]]]:
    """A progress bar on stderr at a terminal (nothing in a pipe): a spinner and the time
    since the start, so that one long session shows it is working, and the sessions
    counted as they complete. Yields the callbacks ``run`` takes: sessions found (the run's
    first line, said at once: how many and where), and done, where a stdout nobody reads
    any more (``run ... | head -1``) stops the run as Ctrl-C would: ``--out`` as it was."""
    from rich.console import Console
    from rich.progress import (
        BarColumn,
        MofNCompleteColumn,
        Progress,
        SpinnerColumn,
        TextColumn,
        TimeElapsedColumn,
    )

    columns = (SpinnerColumn(), TextColumn("sessions"), BarColumn(), MofNCompleteColumn())
    with Progress(
        *columns, TimeElapsedColumn(), console=Console(stderr=True), transient=True
    ) as progress:
        task = progress.add_task("sessions", total=None)

        def found(n: int) -> None:
            progress.update(task, total=n)
            if n:
                typer.echo(f"twopose: analysing {n} session(s) into {out}")
                sys.stdout.flush()

        def done(_path: str, _ok: bool) -> None:
            progress.advance(task)
            if _stdout_closed():
                raise BrokenPipeError(errno.EPIPE, "nobody reads the run's output any more")

        yield found, done


def _sessions_whose(result: RunResult, flag: str) -> tuple[int, int]:
    """How many sessions had ``flag`` (``analysis_reused``, ``figures_reused``) on every row
    they were analysed as, of how many: sessions, not a fork's branches."""
    rows: dict[str, list[bool]] = {}
    for s in result.sessions:
        rows.setdefault(s.session_id, []).append(bool(getattr(s, flag)))
    return sum(all(flags) for flags in rows.values()), len(rows)


def _print_run(result: RunResult, out: Path, *, include_warned: bool) -> None:
    """The per-method and per-session summary (80 columns at a terminal, whole lines when
    piped), the skipped and failed inputs; exit 1 if any input failed."""
    import shutil

    from analysis.report.terminal import closing_lines, summary_lines, wrap_phrases

    width = min(shutil.get_terminal_size().columns, 100) if sys.stdout.isatty() else None
    written = result.written_to is not None
    where = f"results in {out}" if written else f"nothing written, {out} left as it was"
    typer.echo(f"twopose: {result.sessions_said()}, {where}")
    from analysis.rig.scope import rig_lines

    for line in rig_lines(result):
        typer.echo(line)
    for line in summary_lines(
        result.trials, result.summary, include_warned=include_warned, width=width
    ):
        typer.echo(line)
    warned = int(result.summary["n_warned"].sum()) if len(result.summary) else 0
    if warned and not include_warned:
        from analysis.tables.row_units import rows_counted

        footer = [
            f"{rows_counted(result.summary, 'n_warned', ok=True, least=1)} with a "
            "warning (trials.csv's warning says which)",
            "are left out of these statistics",
            "(--include-warned keeps them)",
        ]
        for line in wrap_phrases(footer, width):
            typer.echo(line)
    say_skipped(list(result.skipped))
    for text in result.input_notes:
        note(text)
    for _, e in result.errors.iterrows():
        typer.secho(f"failed: {e['error']}", err=True, fg=typer.colors.RED)
    if result.figures_reused:
        reused, of = _sessions_whose(result, "figures_reused")
        typer.echo(
            f"figures: {reused} of {of} session(s)' reused "
            f"from the last run into {out} (nothing they show changed)"
        )
    if result.sessions_reused:
        reused, of = _sessions_whose(result, "analysis_reused")
        typer.echo(
            f"analysis: {reused} of {of} session(s)' reused "
            f"from the last run into {out} (nothing it depends on changed)"
        )
    for line in closing_lines(result.verdict, out, width=width) if written else ():
        typer.echo(line)
    if result.failed or not result.sessions:
        if not result.sessions and result.errors.empty:
            said = (
                "no measurement session to analyse (see the notes above)"
                if result.input_notes
                else "no session files (*.mcap) found"
            )
            typer.secho(said, err=True, fg=typer.colors.YELLOW)
        raise typer.Exit(EXIT_SOME_INPUTS_FAILED)
