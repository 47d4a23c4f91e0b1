"""``twopose-record``: the lab operator's command line (a thin layer over the library)."""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Annotated, cast

import typer

from recorder.errors import EXIT_ERROR, EXIT_INTERRUPTED, InputValueError, TwoposeError

if TYPE_CHECKING:
    from recorder.live import LiveView
    from recorder.procedure import CaptureResult, RecordingSummary
    from recorder.session import Camera

__all__ = ["app", "handle_errors", "main"]

app = typer.Typer(
    name="twopose-record",
    help="Record twopose measurement sessions (frames, typed poses, ground truth) into MCAP.",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)


@app.callback()
def _group() -> None:
    """Record twopose measurement sessions."""


class MethodChoice(StrEnum):
    point = "point"
    line = "line"
    ground = "ground"


@contextmanager
def handle_errors() -> Iterator[None]:
    """Turn twopose errors into a one-line message and an exit code (the CLIs' only place)."""
    try:
        yield
    except TwoposeError as err:
        typer.secho(f"error: {err}", err=True, fg=typer.colors.RED)
        raise typer.Exit(EXIT_ERROR) from None
    except KeyboardInterrupt:
        typer.secho("interrupted", err=True)
        raise typer.Exit(EXIT_INTERRUPTED) from None


@app.command()
def simulate(
    out: Annotated[Path, typer.Argument(help="New session file to write (never overwritten).")],
    method: Annotated[MethodChoice, typer.Option(help="What the session measures.")],
    trials: Annotated[int, typer.Option(min=1, help="Trials in the session.")] = 15,
    frames: Annotated[int, typer.Option(min=1, help="Frames captured per pose.")] = 5,
    seed: Annotated[
        int, typer.Option(help="Random seed; the same seed writes the same bytes.")
    ] = 0,
    pose_noise: Annotated[
        float | None,
        typer.Option(
            "--pose-noise",
            metavar="SIGMA",
            help="Std. dev. of the operator's error on each moving translation axis, "
            "session units [default: the scene's poses.noise_sigma, 0.1 in].",
        ),
    ] = None,
    poses: Annotated[
        int | None, typer.Option(min=2, help="Poses per trial [default: the scene's, 2].")
    ] = None,
    scene: Annotated[
        Path | None,
        typer.Option(exists=True, dir_okay=False, help="Scene TOML overriding the defaults."),
    ] = None,
) -> None:
    """Render a simulated session of the laptop-on-grid procedure with known truth."""
    from recorder.scene import load_scene
    from recorder.simulate import simulate_session

    with handle_errors():
        summary = simulate_session(
            out,
            method=method.value,
            trials=trials,
            frames=frames,
            seed=seed,
            scene=load_scene(scene),
            pose_noise=pose_noise,
            poses=poses,
        )
    typer.echo(
        f"wrote {summary.path}: {summary.method}, {summary.n_trials} trials, "
        f"{summary.n_poses} poses, {summary.n_frames} frames, {summary.size_bytes / 1e6:.2f} MB"
    )


@app.command()
def new(
    out: Annotated[Path, typer.Argument(help="New session file (never overwritten).")],
    plan: Annotated[
        Path | None,
        typer.Option(exists=True, dir_okay=False, help="Run this plan (TOML) without prompts."),
    ] = None,
    source: Annotated[
        str, typer.Option(help="camera:N, video:PATH, images:DIR or synthetic[:SCENE.toml].")
    ] = "camera:0",
    method: Annotated[MethodChoice | None, typer.Option(help="Asked if not given.")] = None,
    units: Annotated[str | None, typer.Option(help="in, mm, cm or m. Asked if not given.")] = None,
    calibration: Annotated[
        Path | None,
        typer.Option(
            exists=True, dir_okay=False, help="Intrinsics from `twopose-record calibrate`."
        ),
    ] = None,
    focal: Annotated[float | None, typer.Option(help="Focal parameter, px (thesis: 525).")] = None,
    principal: Annotated[str | None, typer.Option(help="Principal point 'cx,cy', px.")] = None,
    ground_height: Annotated[
        float | None, typer.Option(help="Camera centre to table top (method 2).")
    ] = None,
    ground_truth: Annotated[
        list[str] | None,
        typer.Option(help="Measured 'x,y,z' (twice for a line). Asked if not given."),
    ] = None,
    operator: Annotated[str | None, typer.Option(help="Who records.")] = None,
    notes: Annotated[str, typer.Option(help="Free text about the session.")] = "",
    frames: Annotated[int, typer.Option(min=1, help="Frames captured per pose.")] = 5,
    poses: Annotated[int, typer.Option(min=2, help="Poses per trial.")] = 2,
    width: Annotated[int, typer.Option(min=1, help="Camera width to request.")] = 640,
    height: Annotated[int, typer.Option(min=1, help="Camera height to request.")] = 480,
    fps: Annotated[float, typer.Option(min=1, help="Camera frame rate to request.")] = 30.0,
    live: Annotated[
        bool,
        typer.Option(
            help="Serve frames, detections and status to Foxglove (WebSocket, loopback only)."
        ),
    ] = False,
    live_port: Annotated[int, typer.Option(min=0, max=65535, help="Port of --live.")] = 8765,
) -> None:
    """Record a session: the guided laptop-on-grid procedure, or a plan file (--plan)."""
    from recorder.procedure import load_plan, record_plan
    from recorder.sources import open_source

    with handle_errors(), contextlib.ExitStack() as stack:
        if plan is not None:
            the_plan = load_plan(plan)
            src = open_source(source, method=the_plan.method, width=width, height=height, fps=fps)
            view = _live_view(stack, list(the_plan.cameras), live_port) if live else None
            summary = record_plan(the_plan, out, src, on_capture=_report_capture, live=view)
        else:
            summary = _interactive(
                out,
                source,
                method,
                units,
                calibration,
                focal,
                principal,
                ground_height,
                ground_truth,
                operator,
                notes,
                frames,
                poses,
                width,
                height,
                fps,
                (stack, live_port) if live else None,
            )
    typer.echo(
        f"wrote {summary.path}: {summary.n_trials} trials, {summary.n_captures} captures, "
        f"{summary.n_frames} frames ({summary.n_found} detected, {summary.dropped} dropped) "
        f"in {summary.seconds:.1f} s"
    )


def _live_view(stack: contextlib.ExitStack, cameras: list[Camera], port: int) -> LiveView:
    from recorder.live import LiveView

    view = stack.enter_context(LiveView(cameras, port=port))
    typer.echo(
        f"live view on {view.url}: in Foxglove, Open connection > Foxglove WebSocket", err=True
    )
    return view


def _report_capture(trial: int, pose: int, result: CaptureResult) -> None:
    for fb in result.feedback:
        typer.echo(fb.line())
    state = "complete" if result.complete else f"INCOMPLETE: {result.reason}"
    typer.echo(
        f"trial {trial} pose {pose}: {result.n_frames} frames, {result.n_found} detected, "
        f"{state}, {result.dropped} dropped"
    )


def _interactive(
    out: Path,
    source: str,
    method: MethodChoice | None,
    units: str | None,
    calibration: Path | None,
    focal: float | None,
    principal: str | None,
    ground_height: float | None,
    ground_truth: list[str] | None,
    operator_name: str | None,
    notes: str,
    frames: int,
    poses: int,
    width: int,
    height: int,
    fps: float,
    live: tuple[contextlib.ExitStack, int] | None = None,
) -> RecordingSummary:
    """Ask for whatever the options did not give, then run the guided procedure."""
    from recorder.camera import Intrinsics
    from recorder.procedure import Operator, parse_vector, record_interactive
    from recorder.session import METHODS, UNITS, Camera, GroundPlane, Method, SessionInfo
    from recorder.sources import open_source

    op = Operator(
        lambda q, d: str(typer.prompt(q, default=d or None, show_default=bool(d))), typer.echo
    )

    def one_of(options: tuple[str, ...]) -> Callable[[str], str]:
        def parse(text: str) -> str:
            if text not in options:
                raise InputValueError(f"choose one of {', '.join(options)}")
            return text

        return parse

    def positive(text: str) -> float:
        try:
            v = float(text)
        except ValueError as err:
            raise InputValueError(f"{text!r} is not a number") from err
        if not (v > 0 and v < 1e6):
            raise InputValueError(f"{text!r} must be a positive, finite number")
        return v

    def pair(text: str) -> tuple[float, float]:
        parts = text.replace(",", " ").split()
        try:
            a, b = (float(p) for p in parts)
        except ValueError as err:
            raise InputValueError(f"type two numbers 'cx, cy', got {text!r}") from err
        return a, b

    m = method.value if method else op.ask("method (point, line, ground)", one_of(METHODS))
    u = units if units in UNITS else op.ask("units (in, mm, cm, m)", one_of(UNITS), "in")
    if calibration is not None:
        from recorder.calibrate import load_calibration

        intrinsics = load_calibration(calibration)
    else:
        f = focal if focal and focal > 0 else op.ask("focal parameter, px", positive, "525")
        cx, cy = (
            pair(principal)
            if principal
            else op.ask("principal point cx, cy (px)", pair, "320, 240")
        )
        intrinsics = Intrinsics(width, height, f, f, cx, cy)
    ground = None
    if m == "ground":
        h = (
            ground_height
            if ground_height and ground_height > 0
            else op.ask(f"ground height: camera centre to table ({u})", positive)
        )
        ground = GroundPlane(h)
    n_truth = 2 if m == "line" else 1
    given = [parse_vector(g, u, what="ground truth") for g in (ground_truth or [])]
    while len(given) < n_truth:
        given.append(
            op.ask(
                f"ground truth point {len(given) + 1} x, y, z ({u})",
                lambda s: parse_vector(s, u, what="ground truth"),
            )
        )
    who = operator_name if operator_name is not None else op.ask("operator", str, "")
    src = open_source(source, method=m, width=width, height=height, fps=fps)
    camera = Camera("cam0", intrinsics)
    info = SessionInfo(
        method=cast("Method", m),  # one of METHODS: checked when it was read
        units=u,
        operator=who,
        notes=notes,
        created_utc=time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime()),
    )
    view = _live_view(live[0], [camera], live[1]) if live is not None else None
    return record_interactive(
        out,
        src,
        op,
        info=info,
        camera=camera,
        ground=ground,
        ground_truth=tuple(given[:n_truth]),
        frames=frames,
        poses_per_trial=poses,
        live=view,
    )


@app.command()
def calibrate(
    out: Annotated[Path, typer.Argument(help="Calibration file to write (TOML).")],
    source: Annotated[str, typer.Option(help="camera:N, video:PATH or images:DIR.")] = "camera:0",
    board: Annotated[
        str, typer.Option(help="Inner corners 'COLSxROWS' of the checkerboard.")
    ] = "9x6",
    square: Annotated[float, typer.Option(min=0, help="Square side, session units.")] = 1.0,
    views: Annotated[int, typer.Option(min=3, help="Board views to collect.")] = 15,
) -> None:
    """Calibrate a camera from a checkerboard; shows the reprojection error."""
    from recorder.calibrate import calibrate as run_calibration
    from recorder.calibrate import save_calibration
    from recorder.sources import open_source

    with handle_errors():
        try:
            cols, rows = (int(v) for v in board.lower().split("x"))
        except ValueError as err:
            raise InputValueError(f"--board must look like 9x6, got {board!r}") from err
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
    i = result.intrinsics
    typer.echo(
        f"wrote {out}: fx {i.fx:.2f}, fy {i.fy:.2f}, cx {i.cx:.2f}, cy {i.cy:.2f}, "
        f"k1 {i.distortion[0]:+.4f}, k2 {i.distortion[1]:+.4f}; "
        f"RMS reprojection error {result.rms_px:.3f} px over {result.n_views} views"
    )


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
    app()
