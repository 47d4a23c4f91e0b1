"""``twopose-record calibrate-pair``: the command line of the pair's calibration.

A short layer over :func:`recorder.calibration.pair.calibrate_pair` (one call from Python):
the options read by their bounds, the pairs said as they are read, the calibration said in
words (angles, baseline, their 1-sigma, the RMS, the leave-one-out check), every refusal a
message, never a traceback. Registered on ``twopose-record``'s app by ``recorder/cli/app.py``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Annotated

import typer

from recorder.calibration.pair_live import LIVE_VIEWS
from recorder.cli.options import read_option as _read
from twopose.errors import InputValueError, handle_errors
from twopose.values.units import Units

if TYPE_CHECKING:
    from recorder.calibration.pair import PairCalibrationRun

__all__ = ["COMMAND_SETTINGS", "calibrate_pair_command", "report_lines"]

#: The command's click settings: arguments beyond its own are kept (not refused by click)
#: so that an unquoted pattern the shell expanded is refused in words.
COMMAND_SETTINGS = {"allow_extra_args": True}


def _thickness(text: str) -> float:
    """``--board-thickness`` by the one number grammar, a length >= 0."""
    from twopose.values.checks import parse_number

    try:
        value = parse_number(text, "--board-thickness")
    except InputValueError as err:
        raise typer.BadParameter(str(err)) from None
    if value < 0:
        raise typer.BadParameter(f"the board's thickness is a length >= 0, got {text}")
    return value


def calibrate_pair_command(  # noqa: PLR0913 - typer: one parameter per option
    ctx: typer.Context,
    out: Annotated[Path, typer.Argument(help="Pair file to write (TOML; never overwritten).")],
    units: Annotated[
        Units, typer.Option(is_eager=True, help="The unit of --square, the baseline and the floor.")
    ],
    square: Annotated[
        float, typer.Option(**_read("BOARD_SQUARE"), help="Square side, in --units.")
    ],
    left: Annotated[
        str | None,
        typer.Option(
            help="Camera 1's stills of the board, a quoted file pattern: 'DIR/left*.jpg'."
        ),
    ] = None,
    right: Annotated[
        str | None,
        typer.Option(help="Camera 2's stills of the same moments: 'DIR/right*.jpg'."),
    ] = None,
    source: Annotated[
        str | None,
        typer.Option(
            help="Instead of stills, two cameras live: 'pair:camera:0,camera:1' (or two "
            "videos, two image folders); a pair is kept when the board moved and both saw "
            "it at once, until --views pairs or Ctrl-C."
        ),
    ] = None,
    views: Annotated[
        int | None,
        typer.Option(
            **_read("VIEWS"),
            help=f"With --source: stop after this many pairs kept (default {LIVE_VIEWS}; "
            "a folder's: every pair).",
        ),
    ] = None,
    board: Annotated[str, typer.Option(help="Inner corners 'COLSxROWS' of the board.")] = "9x6",
    calibration_left: Annotated[
        Path | None,
        typer.Option(
            exists=True,
            dir_okay=False,
            help="Camera 1's calibration file (twopose-record calibrate); with "
            "--calibration-right. Neither: each camera fitted on its own stills.",
        ),
    ] = None,
    calibration_right: Annotated[
        Path | None,
        typer.Option(exists=True, dir_okay=False, help="Camera 2's calibration file."),
    ] = None,
    floor_left: Annotated[
        Path | None,
        typer.Option(
            exists=True,
            dir_okay=False,
            help="Camera 1's still of the board lying on the floor: the floor plane.",
        ),
    ] = None,
    floor_right: Annotated[
        Path | None,
        typer.Option(exists=True, dir_okay=False, help="Camera 2's still of that board."),
    ] = None,
    board_thickness: Annotated[
        float,
        typer.Option(
            parser=_thickness,
            metavar="<length>",
            help="The floor board's printed face above the floor, in --units.",
        ),
    ] = 0.0,
) -> None:
    """Calibrate a pair of cameras from stills of a board both see, or from both cameras
    live: camera 2's pose in camera 1's frame with its covariance, checked by
    leave-one-out, and the floor."""
    from recorder.calibration.pair import PairRequest, calibrate_pair
    from recorder.setup.rules import inner_corners

    with handle_errors():
        if extra := list(ctx.args):  # a pattern left unquoted: the shell expanded it
            raise InputValueError(
                f"{len(extra)} more argument(s) after the options ({', '.join(extra[:3])}...): "
                "quote the file patterns so that the shell does not expand them, e.g. "
                "--left 'photos/left*.jpg' --right 'photos/right*.jpg'"
            )
        try:
            cols, rows = inner_corners(board)
        except InputValueError as err:
            raise InputValueError(f"--board: {err}") from err
        request = PairRequest(
            out=out,
            left=left,
            right=right,
            source=source,
            views=views,
            board=(cols, rows),
            square=float(square),
            units=units,
            calibration_left=calibration_left,
            calibration_right=calibration_right,
            floor_left=floor_left,
            floor_right=floor_right,
            board_thickness=float(board_thickness),
        )
        run = calibrate_pair(request, on_pair=_said, say=lambda line: typer.echo(f"  {line}"))
    for line in report_lines(run):
        typer.echo(line)


def _said(name: str, found: tuple[bool, bool]) -> None:
    words = {True: "found", False: "not found"}
    typer.echo(f"  {name}: board {words[found[0]]} in camera 1, {words[found[1]]} in camera 2")


def _few_views(run: PairCalibrationRun) -> list[str]:
    """What a calibration on few moments leaves out of its sigmas, in words ([] if none).

    The angles' and t's 1-sigma (and the leave-one-out check) hold given the intrinsics;
    fitted on a camera's 3 or 4 own stills, the intrinsics' own error moved OpenCV's
    photographs' pose 4 to 14 of those sigmas, with the check `passed` (a new user's r7 K7).
    """
    from twopose.pair.calibration import ADVISED_VIEWS

    lines = []
    if run.pair.n_views < ADVISED_VIEWS:
        lines.append(
            f"  warning: {run.pair.n_views} pairs: ten to twenty moments are advised, at "
            "several places and tilts; the sigmas of so few say little"
        )
    fitted = [fit.n_views for fit in run.own if fit is not None]
    if fitted and min(fitted) < ADVISED_VIEWS:
        views = " and ".join(map(str, fitted))
        lines.append(
            f"  warning: each camera's intrinsics were fitted here on {views} views; the "
            "sigmas above (and the leave-one-out check) hold given them, and the "
            "intrinsics' own error, not in them, may move the pose further: calibrate each "
            f"camera on {ADVISED_VIEWS} or more views (twopose-record calibrate) and give "
            "--calibration-left and --calibration-right"
        )
    return lines


def report_lines(run: PairCalibrationRun) -> list[str]:
    """What ``calibrate-pair`` says of its calibration, line by line."""
    pc, u = run.pair, run.pair.units
    a, sa = pc.angles_deg, pc.sigma_angles_deg
    t, st = pc.t_2_in_1, pc.sigma_t
    lines = [
        f"wrote {run.path}: camera 2 in camera 1's frame (x right, y down, z forward)",
        f"  angles rx {a[0]:+.3f} ± {sa[0]:.3f}, ry {a[1]:+.3f} ± {sa[1]:.3f}, "
        f"rz {a[2]:+.3f} ± {sa[2]:.3f} deg (R = Rx Ry Rz)",
        f"  t ({t[0]:+.4g} ± {st[0]:.2g}, {t[1]:+.4g} ± {st[1]:.2g}, {t[2]:+.4g} ± {st[2]:.2g}) "
        f"{u}; baseline {pc.baseline:.4g} {u}",
        f"  RMS reprojection error {pc.rms_px:.3f} px over {pc.n_views} pairs of "
        f"{'stills' if run.live is None or run.live.stills else 'frames'}; "
        f"intrinsics: {pc.intrinsics_from}",
    ]
    lines += _few_views(run)
    for dropped in pc.dropped:
        lines.append(f"  dropped as an outlier and fitted again: {dropped}")
    for skipped in run.skipped:
        lines.append(f"  not used: {skipped}")
    if run.live is not None:
        d = run.live.dropped
        lines.append(
            f"  from the cameras: {run.live.ended}; frames dropped (the board search is "
            f"slower than the cameras): camera 1 {d[0]}, camera 2 {d[1]}"
        )
    c = pc.check
    if c is not None:
        verdict = "passed" if c.passed else "FAILED: the covariance is not confirmed"
        lines.append(
            f"  leave-one-out: {c.spacings} held-out corner spacings over {c.folds} folds, worst "
            f"{c.worst_sigmas:.2f} sigma ({c.beyond} beyond 3), median |error| "
            f"{c.median_error:.3g} {u} against a median sigma of {c.median_sigma:.3g} {u}: "
            f"{verdict}"
        )
        lines.append(
            f"  the folds' scatter over the fit's sigma: {_ratios(c.jackknife_ratio)}; the "
            f"covariance is widened by a variance factor of {pc.cov_factor:.2f}"
        )
    if pc.floor is not None:
        f = pc.floor
        n = f.normal
        lines.append(
            f"  floor: normal ({n[0]:+.4f}, {n[1]:+.4f}, {n[2]:+.4f}) ± {f.sigma_tilt_deg:.2f} "
            f"deg, height {f.height:.4g} ± {f.sigma_height:.2g} {u} below camera 1"
        )
    return lines


def _ratios(values: tuple[float, ...]) -> str:
    names = ("rx", "ry", "rz", "tx", "ty", "tz")
    return ", ".join(f"{n} {v:.2f}" for n, v in zip(names, values, strict=False))
