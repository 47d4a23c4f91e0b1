"""``twopose-analyze``: the analyst's command line (a thin layer over the library)."""

from __future__ import annotations

import contextlib
import dataclasses
import json
import math
import sys
from collections.abc import Callable, Iterator
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from twopose.errors import (
    EXIT_SOME_INPUTS_FAILED,
    InputValueError,
    TwoposeError,
    handle_errors,
    run_command_line,
)
from twopose.methods import Method
from twopose.text import for_terminal
from twopose.version import VersionOption

if TYPE_CHECKING:
    from analysis.results import RunResult
    from twopose.format.trials import SessionOverview

# Everything heavy (numpy, rich, mcap, pandas, matplotlib) is imported inside the command
# that needs it, so that `twopose-analyze --help` starts fast.

__all__ = ["app", "main"]

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

    from analysis.batch import split_inputs
    from twopose.format.trials import describe_session

    console = Console()
    with handle_errors():
        sessions, skipped = split_inputs(paths)
    _say_skipped(skipped)
    overviews: list[SessionOverview] = []
    failed: list[tuple[str, str]] = []
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
            f" ({o.n_set_aside} set aside, {o.n_incomplete_captures} incomplete)"
            if o.n_set_aside or o.n_incomplete_captures
            else ""
        )
        table.add_row(
            escape(for_terminal(str(o.path))),
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


def _say_skipped(skipped: list[str]) -> None:
    if skipped:
        typer.secho(
            f"skipped {len(skipped)} results file(s) of an earlier twopose-analyze run (not "
            f"sessions): {', '.join(skipped)}",
            err=True,
            fg=typer.colors.YELLOW,
        )


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


JunitOption = Annotated[
    Path | None,
    typer.Option(
        "--junit",
        help="Also write JUnit XML here: one test case per session and method.",
        metavar="FILE",
    ),
]


class RigCalibration(StrEnum):
    none = "none"
    loo = "loo"


class CombineChoice(StrEnum):
    mean = "mean"
    median = "median"
    robust = "robust"


SessionTimeoutOption = Annotated[
    float,
    typer.Option(
        min=0.0,
        help="Stop a session still running after this many seconds and list it as failed "
        "(0: no limit).",
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
RigFileOption = Annotated[
    Path | None,
    typer.Option(
        exists=True,
        dir_okay=False,
        help="Correct every view by the rig's constants from `twopose-analyze rig`.",
    ),
]
RigCalibrationOption = Annotated[
    RigCalibration,
    typer.Option(
        help="loo: also each trial corrected by constants its session's other trials give "
        "(x_rig, y_rig, z_rig, err_rig; rig.csv).",
    ),
]


@app.command("run")
def run_command(
    paths: Annotated[list[Path], typer.Argument(help="Session files and/or folders (recursive).")],
    out: Annotated[
        Path, typer.Option("--out", help="Output folder for tables, figures, report.")
    ] = Path("results"),
    jobs: Annotated[
        int, typer.Option(min=1, help="Worker processes (results do not depend on it).")
    ] = 1,
    dask: Annotated[
        str | None,
        typer.Option(help="Address of an existing Dask scheduler to run the sessions on."),
    ] = None,
    combine: Annotated[
        CombineChoice, typer.Option(help="How a pose's frames are combined (thesis: mean).")
    ] = CombineChoice.mean,
    min_parallax: Annotated[
        float, typer.Option(help="Warn when a point's ray parallax is below this (deg).")
    ] = 1.0,
    min_plane_angle: Annotated[
        float, typer.Option(help="Warn when back-projected planes meet below this (deg).")
    ] = 5.0,
    min_ground_angle: Annotated[
        float, typer.Option(help="Warn when the line meets the ground below this (deg).")
    ] = 10.0,
    scene: Annotated[
        bool,
        typer.Option(
            help="Also write results_<n>_<session>.mcap per session: images with the "
            "detections drawn, and each trial's 3-D geometry, for Foxglove."
        ),
    ] = True,
    session_timeout: SessionTimeoutOption = 600.0,
    include_warned: IncludeWarnedOption = False,
    junit: JunitOption = None,
    rig: RigFileOption = None,
    rig_calibration: RigCalibrationOption = RigCalibration.none,
) -> None:
    """Replay sessions through detection and solvers into error tables, figures and a report."""
    from analysis.batch import run
    from analysis.outputs import check_run_outputs, write_file
    from analysis.results import AnalysisOptions

    options = AnalysisOptions(
        combine=combine.value,
        min_parallax_deg=min_parallax,
        min_plane_angle_deg=min_plane_angle,
        min_ground_angle_deg=min_ground_angle,
        session_timeout_s=session_timeout or None,
        include_warned=include_warned,
        rig_calibration=rig_calibration.value,
    )
    with handle_errors(), _session_progress() as (found, done):
        check_run_outputs(paths, out, junit, rig)  # before anything is written
        if rig is not None:
            from analysis.calibration import rig_for_run

            options = dataclasses.replace(options, rig=rig_for_run(rig, paths, _note))
        result = run(
            paths,
            out,
            jobs=jobs,
            dask_address=dask,
            options=options,
            on_session_done=done,
            on_sessions_found=found,
            scene=scene,
        )
        if junit is not None:
            from analysis.gate import junit_xml, run_cases

            cases = run_cases(result.summary, result.errors)
            write_file(junit, junit_xml("twopose-analyze run", cases))
    _print_run(result, out, include_warned)


def _note(text: str) -> None:
    typer.secho(f"note: {text}", err=True)


@contextlib.contextmanager
def _session_progress() -> Iterator[tuple[Callable[[int], None], Callable[[str, bool], None]]]:
    """A progress bar on stderr at a terminal (nothing in a pipe): a spinner and the time
    since the start, so that one long session shows it is working, and the sessions
    counted as they complete. Yields the callbacks ``run`` takes: sessions found, done."""
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
        yield (
            lambda n: progress.update(task, total=n),
            lambda _path, _ok: progress.advance(task),
        )


@app.command("check")
def check_command(
    results: Annotated[Path, typer.Argument(help="The --out folder of the run to check.")],
    baseline: Annotated[
        Path, typer.Option("--baseline", help="The --out folder of the run to compare with.")
    ],
    tolerance: Annotated[
        Path | None,
        typer.Option(
            "--tolerance",
            help="TOML file of allowances (default: RMSE and median 10%, |bias| 10% or "
            "0.05 units, n_ok 0, coverage 0.05); see docs/ci.md.",
        ),
    ] = None,
    junit: JunitOption = None,
) -> None:
    """The CI gate: compare summary.csv with a baseline's, per session and method (RMSE,
    median, |bias|, n_ok, coverage); print what got worse; exit 1 on a regression beyond
    the tolerance."""
    from analysis.gate import check, check_cases, check_lines, junit_xml
    from analysis.outputs import Inputs, write_file

    with handle_errors():
        read = Inputs(files=(tolerance,) if tolerance else (), folders=(results, baseline))
        read.check_file("--junit", junit)
        outcome = check(results, baseline, tolerance)
        if junit is not None:
            write_file(junit, junit_xml("twopose-analyze check", check_cases(outcome)))
    typer.echo("\n".join(check_lines(outcome, baseline)))
    if outcome.regressed:
        raise typer.Exit(EXIT_SOME_INPUTS_FAILED)


def _print_run(result: RunResult, out: Path, include_warned: bool) -> None:
    """The per-method and per-session summary (80 columns at a terminal, whole lines when
    piped), the skipped and failed inputs; exit 1 if any input failed."""
    import shutil

    from analysis.console import closing_lines, summary_lines, wrap_phrases

    width = min(shutil.get_terminal_size().columns, 100) if sys.stdout.isatty() else None
    typer.echo(f"twopose: {len(result.sessions)} session(s), results in {out}")
    for line in summary_lines(
        result.trials, result.summary, include_warned=include_warned, width=width
    ):
        typer.echo(line)
    warned = int(result.summary["n_warned"].sum()) if len(result.summary) else 0
    if warned and not include_warned:
        footer = [
            f"{warned} ok trial(s) with a near-degeneracy warning",
            "are left out of these statistics",
            "(--include-warned keeps them)",
        ]
        for line in wrap_phrases(footer, width):
            typer.echo(line)
    _say_skipped(list(result.skipped))
    for _, e in result.errors.iterrows():
        typer.secho(f"failed: {e['error']}", err=True, fg=typer.colors.RED)
    for line in closing_lines(result.trials, out, include_warned=include_warned, width=width):
        typer.echo(line)
    if result.failed or not result.sessions:
        if not result.sessions and result.errors.empty:
            typer.secho("no session files (*.mcap) found", err=True, fg=typer.colors.YELLOW)
        raise typer.Exit(EXIT_SOME_INPUTS_FAILED)


class EstimatorChoice(StrEnum):
    thesis = "thesis"
    optimal = "optimal"
    weighted = "weighted"


@app.command("compare")
def compare_command(
    run_a: Annotated[Path, typer.Argument(help="The --out folder of run A.")],
    run_b: Annotated[Path, typer.Argument(help="The --out folder of run B.")],
    out: Annotated[
        Path, typer.Option("--out", help="Folder for the tables, compare.png, compare.html.")
    ] = Path("comparison"),
    estimator_a: Annotated[
        EstimatorChoice, typer.Option(help="Estimator read from run A.")
    ] = EstimatorChoice.thesis,
    estimator_b: Annotated[
        EstimatorChoice, typer.Option(help="Estimator read from run B.")
    ] = EstimatorChoice.thesis,
    include_warned: Annotated[
        bool, typer.Option("--include-warned", help="Also use trials with a warning.")
    ] = False,
) -> None:
    """Compare two runs: statistics side by side, and paired differences (B - A) on the
    trials both measured, with a 95% interval and a sign-flip test, per method."""
    from analysis.comparison import compare, describe_test

    with handle_errors():
        comparison = compare(
            run_a,
            run_b,
            out,
            estimator_a=estimator_a.value,
            estimator_b=estimator_b.value,
            include_warned=include_warned,
        )
    typer.echo(f"A: {comparison.a.label}\nB: {comparison.b.label}")
    for _, row in comparison.tests.iterrows():
        typer.echo(describe_test(row))
    if comparison.tests.empty:
        typer.echo("no trial measured in both runs")
    typer.echo(f"wrote {out / 'compare.html'} and its tables")


@app.command("rig")
def rig_command(
    sessions: Annotated[
        list[Path], typer.Argument(help="Calibration sessions (one method, known targets).")
    ],
    out: Annotated[Path, typer.Option("--out", help="The rig file to write.")] = Path("rig.toml"),
    constants: Annotated[
        list[str] | None,
        typer.Option(
            "--constant",
            help="Fit this group (repeatable): mount_rotation_deg, camera_offset, focal_scale, "
            "principal_offset_px, tape_scale, ground_height_error [default: those "
            "leave-one-out cross-validation supports].",
        ),
    ] = None,
) -> None:
    """Estimate the rig's hidden constants from sessions with known targets; write them
    for `run --rig` and `twopose-record new --rig`."""
    from analysis.calibration import calibrate
    from analysis.outputs import run_inputs, write_file
    from analysis.rig import rig_toml

    with handle_errors():
        run_inputs(sessions).check_file("--out", out)  # never a session, FIFO or device
        fit, data = calibrate([str(s) for s in sessions], constants, on_note=_note)
        write_file(out, rig_toml(fit, data.sessions).encode())
    fitted = ", ".join(fit.free) or "nothing"
    typer.echo(f"{len(data.trial_ids)} trial(s) with ground truth; fitted: {fitted}")
    for row in fit.rows():
        if row["fitted"]:
            typer.echo(f"  {row['constant']} = {row['value']:.4g} ± {row['sigma']:.2g}")
    for name, why in fit.fixed.items():
        typer.echo(f"  {name}: fixed ({why})")
    typer.echo(f"wrote {out}")


@app.command("sensitivity")
def sensitivity_command(
    out: Annotated[Path, typer.Option("--out", help="Folder for sensitivity.csv and .png.")] = Path(
        "results"
    ),
    samples: Annotated[int, typer.Option(min=100, help="Monte Carlo samples per point.")] = 2000,
    seed: Annotated[int, typer.Option(help="Random seed.")] = 0,
) -> None:
    """Sweeps of error against pixel noise, pose error per axis, baseline, distance, finger
    angle, in the thesis' geometry; and a check of its 0.1 in -> 0.2 in claim (section 5.3)."""
    from analysis.figures import png_bytes
    from analysis.outputs import OutputFolder, write_atomically
    from analysis.sensitivity import (
        plot_sensitivity,
        sensitivity,
        worst_x_translation_effect,
        x_translation_effect,
    )

    with handle_errors(), OutputFolder.prepare(out):  # the same checks and lock as run's --out
        table = sensitivity(samples=samples, seed=seed)
        write_atomically(out / "sensitivity.csv", table.to_csv(index=False).encode())
        write_atomically(out / "sensitivity.png", png_bytes(plot_sensitivity(table)))
    ours = x_translation_effect()
    worst, tilt, azimuth = worst_x_translation_effect()
    typer.echo(f"wrote {out / 'sensitivity.csv'} ({len(table)} rows) and {out / 'sensitivity.png'}")
    typer.echo(
        f"thesis claim (0.1 in x-translation error moves x by up to ~0.2 in): with our finger "
        f"{ours:.3f} in; worst over finger orientations {worst:.3f} in "
        f"(tilt {tilt:g} deg, azimuth {azimuth:g} deg)"
    )


class TargetChoice(StrEnum):
    glove = "glove"
    dot = "dot"


def _json_float(v: float) -> float | None:
    return None if math.isnan(v) else round(v, 4)


@app.command()
def detect(
    images: Annotated[list[Path], typer.Argument(help="Image files (anything OpenCV reads).")],
    target: Annotated[TargetChoice, typer.Option(help="What to look for.")],
) -> None:
    """Detect the glove or the dot in images; one JSON object per image."""
    from twopose.detect import detect as detect_image
    from twopose.images import decode_image

    failed = False
    for path in images:
        try:
            img = decode_image(path.read_bytes(), str(path)) if path.is_file() else None
            reason = "not a readable image" if img is None else ""
        except (OSError, InputValueError) as err:
            img, reason = None, str(err)
        if img is None:
            failed = True
            out = {
                "image": str(path),
                "found": False,
                "centroid_px": None,
                "theta_deg": None,
                "area_px": None,
                "eccentricity": None,
                "reason": reason or "not a readable image",
            }
        else:
            d = detect_image(img, target.value)
            out = {
                "image": str(path),
                "found": d.found,
                "centroid_px": [_json_float(d.centroid_px[0]), _json_float(d.centroid_px[1])]
                if d.found
                else None,
                "theta_deg": _json_float(d.theta_deg) if d.found else None,
                "area_px": _json_float(d.area_px) if d.found else None,
                "eccentricity": _json_float(d.eccentricity) if d.found else None,
                "reason": d.reason,
            }
        typer.echo(json.dumps(out))
    if failed:
        raise typer.Exit(EXIT_SOME_INPUTS_FAILED)


@app.command()
def solve(method: Annotated[Method, typer.Argument(help="Which reconstruction.")]) -> None:
    """Solve one measurement by hand: a JSON request on stdin, a JSON answer on stdout.

    \b
    The request:
      {"views": [                      two or more, one per camera pose
         {"K": [fx, fy, cx, cy],       intrinsics in pixels
          "pose": {"t": [x, y, z],     camera centre (grid frame, session units)
                   "r_deg": [rx, ry, rz]},   R = Rx Ry Rz, camera to grid
                                       (degrees, optional)
          "px": [col, row]},           point: the target's pixel
         {"P": [[4], [4], [4]],        or the 3x4 projection matrix instead
          "line": {"px": [col, row], "theta_deg": t}},   line, ground: a point
                                       and the orientation of the image line,
                                       or {"segment_px": [x0, y0, x1, y1]}
         ...],
       "ground_y": h,                  ground only: the ground plane y = h
       "estimator": "thesis"}          or "optimal" (point, line), "weighted"
                                       (line; a view may give "sigma_px",
                                       default 1, and "sigma_theta_deg")

    \b
    The answer: {"point": [x, y, z]} or {"line": {"point": [...], "direction":
    [...]}}, with "status", "reason", "conditioning", "n_views" and for points
    "reprojection_rms_px" (optimal lines: also "cov_point", "cov_direction").

    Example: echo '{"views": [{"K": [525, 525, 320, 240], "pose": {"t": [0, 0, 0]},
    "px": [343.9, 311.6]}, {"K": [525, 525, 320, 240], "pose": {"t": [1.1, 0, 0]},
    "px": [291.4, 311.6]}]}' | twopose-analyze solve point
    """
    from analysis.request import solve_request

    with handle_errors():
        try:
            request = json.loads(sys.stdin.read())
        except (ValueError, RecursionError) as err:  # bad JSON, 5000-digit or 1e5-deep values
            raise InputValueError(f"the request is not valid JSON: {err}") from err
        answer = solve_request(method.value, request)
    typer.echo(json.dumps(answer))


def main() -> None:
    """The command line's entry point (``[project.scripts]``, ``python -m``)."""
    run_command_line(app)
