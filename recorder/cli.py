"""``twopose-record``: the lab operator's command line (a thin layer over the library)."""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from enum import StrEnum
from pathlib import Path
from typing import Annotated

import typer

from recorder.errors import EXIT_ERROR, EXIT_INTERRUPTED, TwoposeError

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
    width: Annotated[int, typer.Option(min=1, help="Camera width to request.")] = 640,
    height: Annotated[int, typer.Option(min=1, help="Camera height to request.")] = 480,
    fps: Annotated[float, typer.Option(min=1, help="Camera frame rate to request.")] = 30.0,
) -> None:
    """Record a session: the laptop-on-grid procedure, from a plan file (--plan)."""
    from recorder.procedure import load_plan, record_plan
    from recorder.sources import open_source

    if plan is None:
        typer.secho(
            "error: interactive recording is not available in this version; give --plan PLAN.toml",
            err=True,
            fg=typer.colors.RED,
        )
        raise typer.Exit(EXIT_ERROR)
    with handle_errors():
        the_plan = load_plan(plan)
        src = open_source(source, method=the_plan.method, width=width, height=height, fps=fps)

        def on_capture(trial: int, pose: int, result: object) -> None:
            from recorder.procedure import CaptureResult

            assert isinstance(result, CaptureResult)
            for fb in result.feedback:
                typer.echo(fb.line())
            state = "complete" if result.complete else f"INCOMPLETE: {result.reason}"
            typer.echo(
                f"trial {trial} pose {pose}: {result.n_frames} frames, "
                f"{result.n_found} detected, {state}"
            )

        summary = record_plan(the_plan, out, src, on_capture=on_capture)
    typer.echo(
        f"wrote {summary.path}: {summary.n_trials} trials, {summary.n_captures} captures, "
        f"{summary.n_frames} frames ({summary.n_found} detected) in {summary.seconds:.1f} s"
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
