"""``twopose-analyze rig``, ``sensitivity``, ``detect`` and ``solve``: the rig's constants,
the sweeps, and one image or one measurement by hand."""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from twopose.errors import (
    EXIT_SOME_INPUTS_FAILED,
    InputValueError,
    handle_errors,
)
from twopose.methods.specs import METHOD_SPECS, Method
from twopose.values import jsonsafe
from twopose.values.choices import TARGET_SPECS, Target
from twopose.values.options import read_option, registered
from twopose.values.units import Units

if TYPE_CHECKING:
    pass

from analysis.cli.app import app, note


@app.command("rig")
def rig_command(
    sessions: Annotated[
        list[Path],
        typer.Argument(
            help="Calibration sessions: board sessions, or sessions of one method with known "
            "targets."
        ),
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
    """Estimate the rig's hidden constants from board sessions or from sessions with known
    targets; write them for `run --rig` and `twopose-record new --rig`."""
    from analysis.batch.inputs import resolve_inputs
    from analysis.batch.outputs import run_inputs, write_file
    from analysis.rig.calibrate import calibrate_rig, placing_against_truth
    from analysis.rig.fit import rig_toml
    from analysis.rig.scope import RIG_BESIDE

    with handle_errors():
        inputs = resolve_inputs(sessions)  # once: the check and the fit take this set
        run_inputs(inputs).check_file("--out", out)  # never a session, FIFO or device
        found = calibrate_rig(inputs, constants, on_note=note)
        text = rig_toml(found.fit, found.sessions, found.warnings, found.basis, found.placing)
        write_file(out, text.encode())
    fit = found.fit
    fitted = ", ".join(fit.free) or "nothing"
    typer.echo(f"{found.basis}; fitted: {fitted}")
    for row in fit.rows():
        if row["fitted"]:
            typer.echo(f"  {row['constant']} = {row['value']:.4g} ± {row['sigma']:.2g}")
    for name, why in fit.fixed.items():
        typer.echo(f"  {name}: fixed ({why})")
    if found.placing is not None:
        units = fit.constants.units or Units.IN
        typer.echo(f"  {found.placing.describe(units)}")
        if found.true_placing is not None:
            typer.echo(f"  {placing_against_truth(found.placing, found.true_placing, units)}")
    else:
        typer.echo("  placing sigma: not measured (only a board session measures it)")
    for warning in found.warnings:
        typer.secho(f"warning: {warning}", err=True, fg=typer.colors.YELLOW)
    typer.echo(f"wrote {out}")
    if out.name == RIG_BESIDE:  # a rig.toml has a scope: say it (docs/rig.md)
        where = "this folder" if out.parent == Path() else str(out.parent)
        typer.echo(
            f"  `twopose-analyze run` applies it to every session in {where} and below (the "
            "nearest rig.toml up the tree wins; --rig FILE and --no-rig choose otherwise)"
        )


@app.command("sensitivity")
def sensitivity_command(
    out: Annotated[Path, typer.Option("--out", help="Folder for sensitivity.csv and .png.")] = Path(
        "results"
    ),
    samples: Annotated[
        int, typer.Option(**read_option("SAMPLES"), help="Monte Carlo samples per point.")
    ] = 2000,
    seed: Annotated[int, typer.Option(**read_option("SEED"), help="Random seed.")] = 0,
) -> None:
    """Sweeps of error against pixel noise, pose error per axis, baseline, distance, finger
    angle, in the thesis' geometry; and a check of its 0.1 in -> 0.2 in claim (section 5.3)."""
    from analysis.batch.outputs import OutputFolder, write_atomically
    from analysis.report.figures.draw import png_bytes
    from analysis.tools.sensitivity import (
        plot_sensitivity,
        sensitivity,
        worst_x_translation_effect,
        x_translation_effect,
    )

    # The same checks, lock and transaction as run's --out.
    with handle_errors(), OutputFolder.prepare(out) as folder:
        table = sensitivity(samples=samples, seed=seed)
        write_atomically(folder.path / "sensitivity.csv", table.to_csv(index=False).encode())
        write_atomically(folder.path / "sensitivity.png", png_bytes(plot_sensitivity(table)))
        folder.record(["sensitivity.csv", "sensitivity.png"])
    ours = x_translation_effect()
    worst, tilt, azimuth = worst_x_translation_effect()
    typer.echo(f"wrote {out / 'sensitivity.csv'} ({len(table)} rows) and {out / 'sensitivity.png'}")
    typer.echo(
        f"thesis claim (0.1 in x-translation error moves x by up to ~0.2 in): with our finger "
        f"{ours:.3f} in; worst over finger orientations {worst:.3f} in "
        f"(tilt {tilt:g} deg, azimuth {azimuth:g} deg)"
    )


def _rounded(numbers: dict[str, object]) -> dict[str, object]:
    """A detection's numbers to four decimals (a non-finite one becomes null when written:
    :func:`twopose.values.jsonsafe.dumps`)."""

    def r(v: object) -> object:
        if isinstance(v, float):
            return round(v, 4) if math.isfinite(v) else v
        return [r(x) for x in v] if isinstance(v, list) else v

    return {k: r(v) for k, v in numbers.items()}


@app.command()
def detect(
    images: Annotated[list[Path], typer.Argument(help="Image files (anything OpenCV reads).")],
    target: Annotated[Target, typer.Option(**registered(TARGET_SPECS), help="What to look for.")],
) -> None:
    """Detect the glove or the dot in images; one JSON object per image."""
    from twopose.camera.images import decode_image
    from twopose.detect.detection import Detection
    from twopose.detect.detection import detect as detect_image

    failed = False
    for path in images:
        try:
            img = decode_image(path.read_bytes(), str(path)) if path.is_file() else None
            reason = "not a readable image" if img is None else ""
        except (OSError, InputValueError) as err:
            img, reason = None, str(err)
        if img is None:
            failed = True
            numbers = Detection(found=False, reason=reason or "not a readable image").to_json()
        else:
            numbers = _rounded(detect_image(img, target).to_json())
        out = {"image": str(path), **numbers}
        typer.echo(jsonsafe.dumps(out))
    if failed:
        raise typer.Exit(EXIT_SOME_INPUTS_FAILED)


@app.command()
def solve(
    method: Annotated[
        Method,
        typer.Argument(
            **registered(METHOD_SPECS, lambda spec: spec.measures, argument=True),
            help="Which reconstruction.",
            show_choices=False,
        ),
    ],
) -> None:
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
    from analysis.tools.solve_request import solve_request

    with handle_errors():
        try:
            request = json.loads(sys.stdin.read())
        except (ValueError, RecursionError) as err:  # bad JSON, 5000-digit or 1e5-deep values
            raise InputValueError(f"the request is not valid JSON: {err}") from err
        answer = solve_request(method, request)
    typer.echo(jsonsafe.dumps(answer))
