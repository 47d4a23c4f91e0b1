"""The command line's options read by :mod:`twopose.bounds` (one reader, one bound), and
the guidance options of ``new``: the stop rule, the suggestions' reach, the taped target
distance and the information-gain stop (issue 46)."""

from __future__ import annotations

from typing import Annotated, Any

import typer

from twopose.bounds import DEFAULT_MIN_GAIN
from twopose.options import read_option

__all__ = [
    "GridOption",
    "MaxPosesOption",
    "MinGainOption",
    "ReachOption",
    "TargetDistanceOption",
    "TargetPrecisionOption",
    "read_option",
]


_read = read_option

TargetPrecisionOption = Annotated[
    float | None,
    typer.Option(
        **_read("TARGET_PRECISION"),
        help="Stop rule: a trial is complete once its 95% region's largest semi-axis is "
        "within this (session units), or at --max-poses.",
    ),
]
MaxPosesOption = Annotated[
    int,
    typer.Option(**_read("MAX_POSES"), help="With --target-precision: a trial's most poses."),
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
