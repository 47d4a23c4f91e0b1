"""The command line's options read by :mod:`twopose.bounds` (one reader, one bound), and
the guidance options of ``new``: the stop rule, the suggestions' reach, the taped target
distance and the information-gain stop (issue 46)."""

from __future__ import annotations

from typing import Annotated, Any

import typer

from twopose.bounds import DEFAULT_MIN_GAIN
from twopose.errors import InputValueError
from twopose.units import Units

__all__ = [
    "GridOption",
    "MaxPosesOption",
    "MinGainOption",
    "ReachOption",
    "TargetDistanceOption",
    "TargetPrecisionOption",
    "read_option",
]


class _Typed(float):
    """A number as read from the command line, with the text it was typed as."""

    text: str = ""


def read_option(quantity: str) -> dict[str, Any]:
    """An option's parser and callback: the text as typed, read by the quantity's one
    reader (:mod:`twopose.bounds`: the grammar and the bound every other path applies), in
    ``--units`` when they were given (an eager option, read first), else in whichever unit
    takes it (the setup reads it again once the units are chosen)."""
    from twopose import bounds

    q: bounds.Quantity = getattr(bounds, quantity)
    count = q.kind is bounds.Kind.COUNT

    def parse(value: Any) -> Any:
        if not isinstance(value, str):  # a default
            return value
        try:
            typed = _Typed(q.parse_text(value.strip()))
        except InputValueError as err:
            raise typer.BadParameter(str(err)) from None
        typed.text = value
        return typed

    def in_units(ctx: typer.Context, value: Any) -> Any:
        if value is None:
            return None
        units = ctx.params.get("units")
        try:
            v = q.read(getattr(value, "text", value), Units(units) if units else None)
        except InputValueError as err:
            raise typer.BadParameter(str(err)) from None
        return int(v) if count else v

    lo, hi = q.limits(Units.IN)
    no_unit = (bounds.Kind.COUNT, bounds.Kind.LENGTH, bounds.Kind.SHARE)
    unit = "" if q.kind in no_unit else f" {q.unit_label(Units.IN)}"
    span = "length" if q.kind is bounds.Kind.LENGTH else f"{lo:g}-{hi:g}{unit}"
    return {"parser": parse, "callback": in_units, "metavar": f"<{span}>"}


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
