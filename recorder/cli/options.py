"""``new``'s options, one alias each, so that ``new`` stays readable: each number read by
:mod:`twopose.values.bounds` (one grammar, one bound: :func:`twopose.values.options.read_option`),
and
the guidance options: the stop rule, the suggestions' reach, the taped target distance and
the information-gain stop (issue 46). An option with a default shown in its help defaults
to None here, so that ``new`` knows which were given (:mod:`recorder.cli.option_rules`)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from recorder.sources.registry import source_help
from twopose.methods.specs import METHOD_SPECS, PLANES, Method
from twopose.values.bounds import DEFAULT_MIN_GAIN
from twopose.values.options import read_option, registered
from twopose.values.units import Units

__all__ = [
    "AdaptiveFramesOption",
    "BoardCornerOption",
    "BoardOption",
    "CalibrationOption",
    "CamerasOption",
    "ClockOffsetOption",
    "ContinueFromOption",
    "DriftOption",
    "DropOption",
    "FocalOption",
    "FpsOption",
    "FramesOption",
    "GridOption",
    "GroundHeightOption",
    "GroundTruthOption",
    "HeightOption",
    "HostOption",
    "JitterOption",
    "LiveOption",
    "LivePortOption",
    "MaxPosesOption",
    "MethodOption",
    "MinGainOption",
    "NoFlashOption",
    "NotesOption",
    "OperatorOption",
    "OutArgument",
    "PairOption",
    "PlanOption",
    "PlaneOffsetOption",
    "PortOption",
    "PosesOption",
    "PrincipalOption",
    "ReachOption",
    "RigOption",
    "SourceOption",
    "SpeedOption",
    "SquareOption",
    "TargetDistanceOption",
    "TargetPrecisionOption",
    "UiOption",
    "UnitsOption",
    "WidthOption",
    "given_options",
    "read_option",
]


_read = read_option

UiOption = Annotated[
    bool,
    typer.Option(
        "--ui", help="Run the procedure in the browser: serve the console, print its URL."
    ),
]
PortOption = Annotated[
    int | None, typer.Option(**_read("PORT"), help="Port of --ui (0: a free one) [default: 0].")
]
HostOption = Annotated[
    str | None,
    typer.Option(
        help="Address --ui listens on; anything but loopback is warned about [default: 127.0.0.1]."
    ),
]


RigOption = Annotated[
    Path | None,
    typer.Option(
        exists=True,
        dir_okay=False,
        help="A calibrated rig (twopose-analyze rig) for the live result and guidance: its "
        "constants correct every view, and its [placing] (measured by a board session) is "
        "the placing sigma of every region [default: none: the typed resolution].",
    ),
]


OutArgument = Annotated[Path, typer.Argument(help="New session file (never overwritten).")]
PairOption = Annotated[
    Path | None,
    typer.Option(
        exists=True,
        dir_okay=False,
        help="A pair file (twopose-record calibrate-pair): record two cameras at once "
        "(--source pair:A,B); each trial is a stream: the target moves, both cameras' frames "
        "flow, and the moments it touches a known grid point are marked (Enter at the "
        "terminal, the console's touch button, or a plan's schedule). No pose is typed.",
    ),
]
PlanOption = Annotated[
    Path | None,
    typer.Option(exists=True, dir_okay=False, help="Run this plan (TOML) without prompts."),
]


def _new_source_help() -> str:
    """``new``'s ``--source``: the one-camera kinds, and with ``--pair`` the pair kinds."""
    from recorder.sources.registry import SOURCE_KINDS

    pairs = [k.syntax for k in SOURCE_KINDS if k.cameras == 2]
    return (
        f"{source_help()[:-1]}; with --pair: {' or '.join(pairs)} (two of these at once, "
        "e.g. pair:camera:0,camera:1)."
    )


SourceOption = Annotated[str, typer.Option(help=_new_source_help())]
MethodOption = Annotated[
    Method | None, typer.Option(**registered(METHOD_SPECS), help="Asked if not given.")
]
UnitsOption = Annotated[
    Units | None,
    typer.Option(is_eager=True, help="Every length's unit. Asked if not given."),
]
CalibrationOption = Annotated[
    Path | None,
    typer.Option(exists=True, dir_okay=False, help="Intrinsics from `twopose-record calibrate`."),
]
FocalOption = Annotated[
    float | None, typer.Option(**_read("FOCAL"), help="Focal parameter, px (thesis: 525).")
]
PrincipalOption = Annotated[str | None, typer.Option(help="Principal point 'cx,cy', px.")]
GroundHeightOption = Annotated[
    float | None,
    typer.Option(
        **_read("GROUND_HEIGHT"),
        help="Camera centre to table top: the ground plane's offset (method 2); the same "
        "as --plane-offset for the ground.",
    ),
]


def plane_offset_help() -> str:
    """``--plane-offset``'s help, from the plane table (:data:`twopose.methods.specs.PLANES`):
    what the offset is for each plane a method may be on."""
    from twopose.methods.specs import METHOD_SPECS

    planes = [
        f"{'/'.join(m for m, s in METHOD_SPECS.items() if s.plane == p)}: {p.name}'s "
        f"{p.equation} ({p.measured})"
        for p in PLANES
    ]
    return (
        "The offset of the method's plane, session units: "
        + "; ".join(planes)
        + ". Refused for a method on no plane. Asked if not given."
    )


PlaneOffsetOption = Annotated[
    float | None, typer.Option(**_read("PLANE_OFFSET"), help=plane_offset_help())
]
GroundTruthOption = Annotated[
    list[str] | None,
    typer.Option(help="Measured 'x,y,z' (twice for a line). Asked if not given."),
]
BoardOption = Annotated[
    str | None,
    typer.Option(help="Board session: the checkerboard's inner corners 'COLSxROWS'."),
]
SquareOption = Annotated[
    float | None,
    typer.Option(
        **_read("BOARD_SQUARE"),
        help="Board session: the board's square side, session units.",
    ),
]
BoardCornerOption = Annotated[
    str | None,
    typer.Option(
        help="Board session: the measured grid point 'x,y,z' of the board's first inner "
        "corner (lower left, seen from the camera)."
    ),
]
OperatorOption = Annotated[str | None, typer.Option(help="Who records.")]
NotesOption = Annotated[str | None, typer.Option(help="Free text about the session.")]
FramesOption = Annotated[
    int | None, typer.Option(**_read("FRAMES"), help="Frames captured per pose [default: 5].")
]
AdaptiveFramesOption = Annotated[
    bool,
    typer.Option(
        help="--frames is the most: a pose stops at 3 or more frames once another would "
        "shrink its measurement's variance by less than 5% (the detector's floor "
        "dominates). A plan sets adaptive_frames."
    ),
]
PosesOption = Annotated[
    int | None,
    typer.Option(
        **_read("POSES"),
        help="Poses per trial, without a stop rule (--target-precision) [default: 2].",
    ),
]
WidthOption = Annotated[
    int | None,
    typer.Option(**_read("IMAGE_SIDE"), help="Camera width to request [default: 640]."),
]
HeightOption = Annotated[
    int | None,
    typer.Option(**_read("IMAGE_SIDE"), help="Camera height to request [default: 480]."),
]
FpsOption = Annotated[
    float | None,
    typer.Option(**_read("FPS"), help="Frame rate to request of a camera [default: 30]."),
]
LiveOption = Annotated[
    bool,
    typer.Option(
        help="Serve frames, detections and status to Foxglove (WebSocket, loopback only)."
    ),
]
LivePortOption = Annotated[
    int | None, typer.Option(**_read("PORT"), help="Port of --live [default: 8765].")
]
ContinueFromOption = Annotated[
    Path | None,
    typer.Option(
        "--continue",
        exists=True,
        dir_okay=False,
        help="Continue this session (closed, or recovered by `recover`): its setup and "
        "id, the trials numbered after its last; a two-camera session's continuation "
        "takes its stored pair (give --source pair:A,B; --pair, if given, must be that pair).",
    ),
]


TargetPrecisionOption = Annotated[
    float | None,
    typer.Option(
        **_read("TARGET_PRECISION"),
        help="Stop rule: a trial is complete once its 95% region's largest semi-axis is "
        "within this (session units), or at --max-poses.",
    ),
]
MaxPosesOption = Annotated[
    int | None,
    typer.Option(
        **_read("MAX_POSES"), help="With --target-precision: a trial's most poses [default: 6]."
    ),
]
ReachOption = Annotated[
    float | None,
    typer.Option(
        **_read("REACH"),
        help="Suggested poses lie within this of a trial's first, in x and z (session "
        "units) [default: the thesis' 3 in].",
    ),
]
GridOption = Annotated[
    float | None,
    typer.Option(
        **_read("GRID"),
        help="The grid paper's spacing: suggested poses lie on it (session units) "
        "[default: the thesis' 1/2 in].",
    ),
]
TargetDistanceOption = Annotated[
    float | None,
    typer.Option(
        **_read("TARGET_DISTANCE"),
        help="The distance from the first pose's camera to the target, taped (session "
        "units): the first suggestion assumes it [default: none taped: the first suggestion "
        "weighs every depth from 8 to 30 in along the first view's ray].",
    ),
]
MinGainOption = Annotated[
    float | None,
    typer.Option(
        **_read("MIN_GAIN"),
        help="With --target-precision: a trial is also complete once the next pose would "
        "shrink its 95% region by less than this share (the information-gain stop; 0: "
        f"none) [default: {DEFAULT_MIN_GAIN:g}].",
    ),
]


# -- simulate --cameras 2 (recorder/simulate/pair.py)
CamerasOption = Annotated[
    int,
    typer.Option(
        **read_option("CAMERAS"),
        help="1: the laptop-on-grid procedure; 2: a pair of cameras fixed to each other "
        "watching a moving target (stream trials; needs --speed and --clock-offset-ms).",
    ),
]
SpeedOption = Annotated[
    float | None,
    typer.Option(
        **read_option("SPEED"),
        help="With --cameras 2: the moving target's speed, session units per second.",
    ),
]
ClockOffsetOption = Annotated[
    float | None,
    typer.Option(
        "--clock-offset-ms",
        **read_option("CLOCK_OFFSET"),
        help="With --cameras 2: camera 2's capture clock minus camera 1's, ms.",
    ),
]
DriftOption = Annotated[
    float | None,
    typer.Option(
        "--drift-ppm",
        **read_option("DRIFT"),
        help="With --cameras 2: camera 2's frame interval longer than camera 1's by "
        "this many parts per million [default: 0].",
    ),
]
JitterOption = Annotated[
    float | None,
    typer.Option(
        "--jitter-ms",
        **read_option("JITTER"),
        help="With --cameras 2: each capture stamp's 1-sigma jitter, ms [default: 0].",
    ),
]
DropOption = Annotated[
    float | None,
    typer.Option(
        **read_option("DROP"),
        help="With --cameras 2: the share of each camera's frames lost [default: 0].",
    ),
]

NoFlashOption = Annotated[
    bool,
    typer.Option(
        "--no-flash",
        help="With --cameras 2: no flash at each stream trial's start (by default one both "
        "cameras see, which measures any clock offset; without it the moving target's rays "
        "must fix the offset).",
    ),
]


def given_options(ctx: typer.Context) -> list[str]:
    """The options a command was given (on its command line, or by their environment
    variables): their first ``--names``."""
    given = []
    for p in ctx.command.params:
        source = ctx.get_parameter_source(p.name) if p.name else None
        if p.opts and source is not None and source.name != "DEFAULT":
            given.append(p.opts[0])
    return given
