"""``twopose-record``: the lab operator's command line (a thin layer over the library)."""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, Any, TypeVar

import typer

from recorder.cli.new_pair import is_pair_session, new_pair
from recorder.cli.options import (
    AdaptiveFramesOption,
    BoardCornerOption,
    BoardOption,
    CalibrationOption,
    ContinueFromOption,
    FocalOption,
    FpsOption,
    FramesOption,
    GridOption,
    GroundHeightOption,
    GroundTruthOption,
    HeightOption,
    HostOption,
    LiveOption,
    LivePortOption,
    MaxPosesOption,
    MethodOption,
    MinGainOption,
    NotesOption,
    OperatorOption,
    OutArgument,
    PairOption,
    PlaneOffsetOption,
    PlanOption,
    PortOption,
    PosesOption,
    PrincipalOption,
    ReachOption,
    RigOption,
    SourceOption,
    SquareOption,
    TargetDistanceOption,
    TargetPrecisionOption,
    UiOption,
    UnitsOption,
    WidthOption,
)
from recorder.cli.options import read_option as _read
from recorder.cli.simulate import simulate
from recorder.sources.registry import source_help
from twopose.errors import (
    EXIT_INTERRUPTED,
    InputValueError,
    TwoposeError,
    handle_errors,
    run_command_line,
)
from twopose.methods.specs import Method
from twopose.values.units import Units
from twopose.version import VersionOption

if TYPE_CHECKING:
    from recorder.calibration.camera import Calibration
    from recorder.cli.option_rules import Combination
    from recorder.procedure.new_session import NewRequest
    from recorder.procedure.summary import RecordingSummary
    from recorder.setup.continuation import Continued
    from recorder.setup.rules import GuidanceAsked
    from twopose.camera.model import Intrinsics
    from twopose.methods.targets import BoardPlacement

__all__ = ["app", "main"]

T = TypeVar("T")

app = typer.Typer(
    name="twopose-record",
    help="Record twopose measurement sessions (frames, typed poses, ground truth) into MCAP.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
    rich_markup_mode=None,  # click's plain help: wrapped at words, never boxed and cut
)


@app.callback()
def _group(version: VersionOption = False) -> None:
    """Record twopose measurement sessions."""


app.command()(simulate)


@app.command()
def new(
    out: OutArgument,
    plan: PlanOption = None,
    source: SourceOption = "camera:0",
    method: MethodOption = None,
    units: UnitsOption = None,
    calibration: CalibrationOption = None,
    focal: FocalOption = None,
    principal: PrincipalOption = None,
    ground_height: GroundHeightOption = None,
    plane_offset: PlaneOffsetOption = None,
    ground_truth: GroundTruthOption = None,
    board: BoardOption = None,
    square: SquareOption = None,
    board_corner: BoardCornerOption = None,
    operator: OperatorOption = None,
    notes: NotesOption = None,
    frames: FramesOption = None,
    adaptive_frames: AdaptiveFramesOption = False,
    poses: PosesOption = None,
    width: WidthOption = None,
    height: HeightOption = None,
    fps: FpsOption = None,
    live: LiveOption = False,
    live_port: LivePortOption = None,
    ui: UiOption = False,
    port: PortOption = None,
    host: HostOption = None,
    rig: RigOption = None,
    target_precision: TargetPrecisionOption = None,
    max_poses: MaxPosesOption = None,
    reach: ReachOption = None,
    continue_from: ContinueFromOption = None,
    grid: GridOption = None,
    target_distance: TargetDistanceOption = None,
    min_gain: MinGainOption = None,
    pair: PairOption = None,
) -> None:
    """Record a session: the guided laptop-on-grid procedure, or a plan file (--plan);
    with --pair, two cameras' stream trials (README, "Two cameras at once").

    After each accepted pose the recorder suggests the next one (the reachable pose that
    shrinks the trial's predicted 95% region most); with --target-precision a trial ends
    as soon as its region is within it. A plan sets these in its [guidance] table.

    Ctrl-C at any point closes the file (valid, with everything accepted so far), prints
    the summary and exits with 130.
    """
    from recorder.cli.option_rules import refuse_idle
    from recorder.procedure import new_session as ns
    from recorder.procedure.machine import refuse_existing

    given = {  # every option by its name, None (False, []) when not given
        "--plan": plan, "--method": method, "--units": units, "--calibration": calibration,
        "--focal": focal, "--principal": principal, "--ground-height": ground_height,
        "--plane-offset": plane_offset, "--ground-truth": ground_truth, "--board": board,
        "--square": square, "--board-corner": board_corner, "--operator": operator,
        "--notes": notes, "--frames": frames, "--poses": poses, "--width": width,
        "--height": height, "--fps": fps, "--live": live, "--live-port": live_port, "--ui": ui,
        "--port": port, "--host": host, "--max-poses": max_poses, "--min-gain": min_gain,
        "--rig": rig, "--continue": continue_from, "--target-precision": target_precision,
        "--reach": reach, "--grid": grid, "--target-distance": target_distance,
        "--adaptive-frames": adaptive_frames,
    }  # fmt: skip
    with handle_errors(), contextlib.ExitStack() as stack:
        refuse_existing(out)  # before the first question
        if pair is not None or (continue_from is not None and is_pair_session(continue_from)):
            # two cameras' stream trials, or a two-camera session's continuation
            raise typer.Exit(new_pair(out, pair, source, given, plan=plan, ui=ui))
        if plan is not None and ui:
            raise InputValueError(
                "--plan records unattended and --ui asks in the browser: give one of them "
                "(the plan's setup and poses are not asked again in the page)"
            )
        guiding = {"--target-precision": target_precision, "--reach": reach, "--grid": grid,
                   "--target-distance": target_distance, "--min-gain": min_gain,
                   "--max-poses": max_poses}  # fmt: skip
        guiding["--adaptive-frames"] = True if adaptive_frames else None
        board_options = _guidance_given(guiding, method, planned=plan is not None)
        continued = ns.continued_session(
            continue_from,
            operator=operator,  # who records this part: recorded, not ignored
            method=method, units=units, calibration=calibration, focal=focal,
            principal=principal, ground_height=ground_height, plane_offset=plane_offset,
            ground_truth=ground_truth, board=board,
        )  # fmt: skip
        asked = replace(
            ns.guidance_asked(max_poses, reach, grid, target_distance, min_gain),
            given=tuple(board_options), poses=poses,
        )  # fmt: skip
        refuse_idle(_combination(given, source, target_precision, continued))
        taken = ""  # a plan's continuation: record_planned takes its session's guidance
        if plan is None:
            asked, taken = _inherited(asked, continued, target_precision)
        ns.say_fork(continued if plan is None else None)  # a plan's: once read and checked
        request = ns.NewRequest(
            out=out, source=source, frames=frames or 5, adaptive_frames=adaptive_frames,
            poses=asked.poses or 2,
            camera=ns.CameraMode(width=width or 640, height=height or 480, fps=fps or 30.0),
            notes=notes or "", **ns.rig_file(rig),
            live_port=(8765 if live_port is None else live_port) if live else None,
            guidance=asked, continued=continued,
        )  # fmt: skip
        summary = _record_new(
            request, stack, plan=plan, ui=ui, host=host or "127.0.0.1", port=port or 0,
            target_precision=target_precision,
            taken=taken,
            setup=lambda: _console_given(
                method, units, calibration, focal, principal, (ground_height, plane_offset),
                ground_truth, operator, _board_given(method, units, board, square, board_corner),
                target_precision,
            ),
        )  # fmt: skip
        if summary is None:  # the console served until it was stopped
            return
    typer.echo(summary.line())
    if summary.interrupted:
        typer.secho("interrupted", err=True)
        raise typer.Exit(EXIT_INTERRUPTED)


def _record_new(
    request: NewRequest,
    stack: contextlib.ExitStack,
    *,
    plan: Path | None,
    ui: bool,
    host: str,
    port: int,
    target_precision: float | None,
    taken: str,
    setup: Callable[[], dict[str, Any]],
) -> RecordingSummary | None:
    """``new`` records: from a plan, continuing a session (terminal or console), or a new
    session (terminal or console); None when the console served until it was stopped.
    ``taken``: the guidance a continuation inherits, said in the console's setup."""
    from recorder.procedure.new_session import (
        continued_given,
        record_planned,
        record_terminal,
        serve_console_until_stopped,
    )

    if plan is not None:
        return record_planned(request, plan, stack)
    if request.continued is not None:
        if ui:
            given_ui = continued_given(request.continued, target_precision, guidance=taken)
            serve_console_until_stopped(request, given_ui, host=host, port=port)
            return None
        return record_terminal(request, {"target_precision": target_precision}, stack)
    if ui:
        serve_console_until_stopped(request, setup(), host=host, port=port)
        return None
    return record_terminal(request, setup(), stack)


def _combination(
    given: dict[str, Any], source: str, target: float | None, continued: Continued | None
) -> Combination:
    """What ``new`` was given, as :func:`recorder.cli.option_rules.refuse_idle` judges it."""
    from recorder.cli.option_rules import Combination
    from recorder.sources.registry import one_camera

    inherited = continued is not None and continued.target95 is not None
    return Combination(
        given=frozenset(k for k, v in given.items() if v not in (None, False, [])),
        source_takes_fps=one_camera(source).takes_fps,  # a pair: refused before any question
        target=target is not None or inherited,
        target_from="--target-precision" if target is not None or continued is None
        else continued.path.name,
        continued="" if continued is None else continued.path.name,
    )  # fmt: skip


def _inherited(
    asked: GuidanceAsked, continued: Continued | None, target: float | None
) -> tuple[GuidanceAsked, str]:
    """A continuation's guidance: what the command line gave, else its session's; and the
    settings taken from the session in words, said once, at the start (the page too)."""
    if continued is None:
        return asked, ""
    from recorder.setup.rules import inherited_words

    units = continued.info.units
    inherited, said = asked.inherited(continued.guidance, units)
    if target is None and continued.target95 is not None:
        said[:0] = inherited_words({"target_95": continued.target95}, units)
    words = f"guidance from {continued.path.name}: {', '.join(said)}" if said else ""
    if not said and continued.guidance is None and continued.target95 is None:
        words = f"guidance: {continued.path.name} recorded none: the defaults"
    if words:
        typer.echo(words)
    return inherited, words


def _guidance_given(guiding: dict[str, Any], method: Method | None, *, planned: bool) -> list[str]:
    """The guidance options ``new`` was given (those of ``guiding`` not None); refused for
    a board session and with a plan."""
    from recorder.setup.rules import board_refusal
    from twopose.methods.specs import spec_of

    given_guidance = [k for k, v in guiding.items() if v is not None]
    if method is not None and not spec_of(method).measures and given_guidance:
        raise InputValueError(board_refusal(given_guidance))
    if planned and given_guidance:
        raise InputValueError(
            f"{', '.join(given_guidance)}: a plan sets its guidance in "
            "its [guidance] table (target_95, reach, spacing, max_poses, target_distance, "
            "min_gain), and "
            "adaptive_frames at its top"
        )
    return given_guidance


def _console_given(
    method: Method | None,
    units: Units | None,
    calibration: Path | None,
    focal: float | None,
    principal: str | None,
    offsets: tuple[float | None, float | None],
    ground_truth: list[str] | None,
    operator: str | None,
    board: BoardPlacement | None = None,
    target_precision: float | None = None,
) -> dict[str, Any]:
    """What the command line gave, as :func:`recorder.procedure.terminal.ask_setup` takes it
    (``offsets``: ``--ground-height`` and ``--plane-offset``, checked by
    :func:`recorder.setup.rules.plane_offsets_given`)."""
    from recorder.setup.rules import PLANE_OFFSET_KEY, parse_vector, plane_offsets_given
    from twopose.methods.specs import PLANES, spec_of
    from twopose.values.bounds import GROUND_TRUTH

    plane_offsets = plane_offsets_given(method, *offsets)
    offset = plane_offsets.get(PLANE_OFFSET_KEY)
    if offset is not None:  # within its plane's bound (any plane's, the method not chosen)
        planes = [spec_of(method).plane] if method is not None else PLANES
        refusals = [p.bound.refusal(offset, units) for p in planes if p is not None]
        if refusals and all(refusals):
            raise typer.BadParameter(refusals[0], param_hint="'--plane-offset'")
    return {
        "method": method.value if method else None,
        "units": units,
        "intrinsics": _calibration(calibration),
        "intrinsics_sigma": _calibration_sigma(calibration),
        "focal": focal,
        "principal": _principal(principal),
        **plane_offsets,  # --ground-height under the ground's key, --plane-offset's own
        "ground_truth": [
            _option("--ground-truth", parse_vector, g, units, quantity=GROUND_TRUTH)
            for g in ground_truth or []
        ],
        "operator": operator,
        "board": board,
        "target_precision": target_precision,
    }


def _board_given(
    method: Method | None,
    units: Units | None,
    board: str | None,
    square: float | None,
    corner: str | None,
) -> BoardPlacement | None:
    """A board session's board from ``--board``, ``--square`` and ``--board-corner`` (given
    together, for a board session only; None: asked)."""
    from recorder.setup.rules import board_corner, inner_corners
    from twopose.methods.specs import spec_of
    from twopose.methods.targets import BoardPlacement

    parts = {"--board": board, "--square": square, "--board-corner": corner}
    given = [name for name, value in parts.items() if value is not None]
    if not given:
        return None
    if method is not None and spec_of(method).measures:
        raise InputValueError(f"{', '.join(given)}: for a board session (--method board) only")
    missing = [name for name, value in parts.items() if value is None]
    if missing:
        raise InputValueError(
            f"give {', '.join(missing)} with {', '.join(given)}: a board session records the "
            "board's size and where it stands together"
        )
    if board is None or square is None or corner is None:  # said above, as missing
        return None
    return BoardPlacement(
        inner_corners=_option("--board", inner_corners, board),
        square=square,  # read by its option's parser
        first_corner=_option("--board-corner", board_corner, corner, units),
    )


def _option(option: str, read: Callable[..., T], *args: Any, **kwargs: Any) -> T:
    """An option's text read as the setup reads it (:mod:`twopose.values.bounds`); a refusal is
    a malformed command line (exit 2) naming the option."""
    try:
        return read(*args, **kwargs)
    except InputValueError as err:
        raise typer.BadParameter(str(err), param_hint=f"'{option}'") from None


def _calibration_sigma(path: Path | None) -> dict[str, float]:
    from recorder.calibration.camera import load_calibration_sigma

    return load_calibration_sigma(path) if path is not None else {}


def _calibration(path: Path | None) -> Intrinsics | None:
    if path is None:
        return None
    from recorder.calibration.camera import load_calibration

    return load_calibration(path)


def _principal(text: str | None) -> tuple[float, float] | None:
    if not text:
        return None
    from recorder.setup.rules import number_pair

    return _option("--principal", number_pair, text)


@app.command()
def calibrate(
    out: Annotated[Path, typer.Argument(help="Calibration file to write (TOML).")],
    source: Annotated[
        str,
        typer.Option(help=source_help(calibration=True)),
    ] = "camera:0",
    board: Annotated[
        str, typer.Option(help="Inner corners 'COLSxROWS' of the checkerboard.")
    ] = "9x6",
    square: Annotated[
        float, typer.Option(**_read("BOARD_SQUARE"), help="Square side, session units.")
    ] = 1.0,
    views: Annotated[
        int | None,
        typer.Option(
            **_read("VIEWS"),
            help="Stop after this many views (default: every still; 15 from a camera).",
        ),
    ] = None,
) -> None:
    """Calibrate a camera from a checkerboard: every distinct view, the sigma of every
    intrinsic, each view's error, outlier views dropped, and the image's coverage."""
    from recorder.calibration.camera import calibrate as run_calibration
    from recorder.calibration.camera import save_calibration
    from recorder.setup.rules import inner_corners
    from recorder.sources.registry import open_source

    with handle_errors():
        try:
            cols, rows = inner_corners(board)
        except InputValueError as err:
            raise InputValueError(f"--board: {err}") from err
        if out.exists():
            raise TwoposeError(f"{out} already exists; choose another calibration file")
        result = run_calibration(
            open_source(source),
            (cols, rows),
            square,
            views=views,
            on_view=lambda i, found: typer.echo(
                f"  frame {i + 1}: board {'found' if found else 'not found'}"
            ),
        )
        save_calibration(result, out)
    _report_calibration(out, result)


def _report_calibration(out: Path, result: Calibration) -> None:
    """The fit's values with their sigmas, the views, and what to worry about."""
    i, s = result.intrinsics, result.sigma
    nan = float("nan")
    typer.echo(
        f"wrote {out}: fx {i.fx:.2f} ± {s.get('fx', nan):.2f}, fy {i.fy:.2f} ± "
        f"{s.get('fy', nan):.2f}, cx {i.cx:.2f} ± {s.get('cx', nan):.2f}, cy {i.cy:.2f} ± "
        f"{s.get('cy', nan):.2f}, k1 {i.distortion[0]:+.4f}, k2 {i.distortion[1]:+.4f}, "
        f"k3 {i.distortion[4]:+.4f}; RMS reprojection error {result.rms_px:.3f} px over "
        f"{result.n_views} views; corners cover {result.coverage:.0%} of the image"
    )
    worst = max(result.view_rms_px)
    median = sorted(result.view_rms_px)[len(result.view_rms_px) // 2]
    typer.echo(f"  per view RMS: median {median:.3f} px, worst {worst:.3f} px")
    for dropped in result.dropped:
        typer.secho(f"  dropped as an outlier and fitted again: {dropped}", fg=typer.colors.YELLOW)
    for warning in result.warnings:
        typer.secho(f"  warning: {warning}", fg=typer.colors.YELLOW)


@app.command()
def recover(
    broken: Annotated[
        Path, typer.Argument(exists=True, dir_okay=False, help="The damaged session.")
    ],
    output: Annotated[Path, typer.Option("-o", "--output", help="The new, valid session file.")],
) -> None:
    """Salvage every complete chunk of an interrupted or damaged session into a new file."""
    from recorder.recover import recover_session

    with handle_errors():
        report = recover_session(broken, output)
    typer.echo(report.summary())


def main() -> None:
    """The command line's entry point (``[project.scripts]``, ``python -m``)."""
    run_command_line(app)


# The pair's calibration lives in its own module (issue 58), registered here.
from recorder.cli.pair import COMMAND_SETTINGS, calibrate_pair_command  # noqa: E402

app.command("calibrate-pair", context_settings=COMMAND_SETTINGS)(calibrate_pair_command)

# Pointing, live (issue 58 item 5): its own module, registered here.
from recorder.cli.point import point_command  # noqa: E402

app.command("point")(point_command)
