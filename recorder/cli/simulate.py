"""``twopose-record simulate``: a session rendered with known truth, the laptop-on-grid
procedure of one camera (:func:`recorder.simulate.one_camera.simulate_session`) or a pair of cameras
watching a moving target (:mod:`recorder.simulate.pair`). Registered on
``twopose-record``'s app by ``recorder/cli/app.py``."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from recorder.cli.options import (
    CamerasOption,
    ClockOffsetOption,
    DriftOption,
    DropOption,
    JitterOption,
    NoFlashOption,
    SpeedOption,
    given_options,
)
from recorder.cli.options import read_option as _read
from twopose.errors import handle_errors
from twopose.methods.specs import METHOD_SPECS, Method
from twopose.values.options import registered

__all__ = ["simulate"]


def simulate(
    ctx: typer.Context,
    out: Annotated[Path, typer.Argument(help="New session file to write (never overwritten).")],
    method: Annotated[
        Method, typer.Option(**registered(METHOD_SPECS), help="What the session measures.")
    ],
    trials: Annotated[int, typer.Option(**_read("TRIALS"), help="Trials in the session.")] = 15,
    frames: Annotated[int, typer.Option(**_read("FRAMES"), help="Frames captured per pose.")] = 5,
    seed: Annotated[
        int,
        typer.Option(**_read("SEED"), help="Random seed; the same seed writes the same bytes."),
    ] = 0,
    pose_noise: Annotated[
        float | None,
        typer.Option(
            "--pose-noise",
            **_read("POSE_NOISE"),
            help="Std. dev. of the operator's error on each moving translation axis, "
            "session units [default: the scene's poses.noise_sigma, 0.1 in].",
        ),
    ] = None,
    typed_resolution: Annotated[
        float | None,
        typer.Option(
            "--typed-resolution",
            **_read("TYPED_RESOLUTION"),
            help="The 1-sigma each pose entry records as its resolution, session units: an "
            "operator whose real placing error (--pose-noise) differs from what they type "
            "[default: the scene's poses.typed_resolution, else the real error].",
        ),
    ] = None,
    poses: Annotated[
        int | None,
        typer.Option(**_read("POSES"), help="Poses per trial [default: the scene's, 2]."),
    ] = None,
    scene: Annotated[
        Path | None,
        typer.Option(exists=True, dir_okay=False, help="Scene TOML overriding the defaults."),
    ] = None,
    cameras: CamerasOption = 1,
    speed: SpeedOption = None,
    clock_offset_ms: ClockOffsetOption = None,
    drift_ppm: DriftOption = None,
    jitter_ms: JitterOption = None,
    drop: DropOption = None,
    no_flash: NoFlashOption = False,
    operator: Annotated[
        str,
        typer.Option(
            help="Who the session names as its operator: an analysis pools the placing "
            "error of one operator's sessions, so scenarios simulated apart are named apart."
        ),
    ] = "twopose simulator",
) -> None:
    """Render a simulated session with known truth: the laptop-on-grid procedure, or
    (--cameras 2) a pair of cameras watching a moving target."""
    from rich.console import Console
    from rich.progress import Progress

    from recorder.simulate.one_camera import poses_per_trial, simulate_session
    from recorder.simulate.pair import refuse_idle_options, simulate_pair_with_progress
    from twopose.sim.scene import load_scene

    with handle_errors():
        refuse_idle_options(cameras, given_options(ctx))
        loaded = load_scene(scene)
        if cameras == 2:
            summary = simulate_pair_with_progress(
                out, method, trials, seed, loaded,
                (speed, clock_offset_ms, drift_ppm, jitter_ms, drop), flash=not no_flash,
                operator=operator,
            )  # fmt: skip
            typer.echo(
                f"wrote {summary.path}: {summary.method}, two cameras, {summary.n_trials} "
                f"stream trial{'' if summary.n_trials == 1 else 's'}, {summary.n_frames} "
                f"frames, {summary.size_bytes / 1e6:.2f} MB"
            )
            return
        total = trials * poses_per_trial(loaded, method, poses) * frames
        # A bar on stderr at a terminal (rendering takes about 0.1 s a frame), nothing in a pipe.
        with Progress(console=Console(stderr=True), transient=True) as progress:
            task = progress.add_task("frames rendered", total=total)
            summary = simulate_session(
                out,
                method=method,
                trials=trials,
                frames=frames,
                seed=seed,
                scene=loaded,
                pose_noise=pose_noise,
                typed_resolution=typed_resolution,
                poses=poses,
                on_progress=lambda: progress.advance(task),
                operator=operator,
            )
    typer.echo(
        f"wrote {summary.path}: {summary.method}, {summary.n_trials} "
        f"trial{'' if summary.n_trials == 1 else 's'}, {summary.n_poses} poses, "
        f"{summary.n_frames} frames, {summary.size_bytes / 1e6:.2f} MB"
    )
