"""The command lines' numbers: every numeric option of both commands read by its quantity.

Click reads an ``int`` or ``float`` option with Python's own grammar (``1_0`` as 10,
full-width digits, ``inf``, ``1e309``) and refuses in its own words; here every number
option's text goes through the one grammar and the quantity's one bound
(:mod:`twopose.values.bounds`), so ``--fps 1_0``, ``--port 8_081`` and ``--seed 0x10`` are refused
in the words the terminal, the page and a plan use, and a value keeps the text it was
typed as (:class:`twopose.values.checks.Given`).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import typer

from twopose.errors import InputValueError
from twopose.registry import Name, Registry, load_extensions
from twopose.values import bounds
from twopose.values.units import Units

__all__ = ["read_option", "registered"]


def read_option(quantity: str) -> dict[str, Any]:
    """An option's parser, callback and metavar for the quantity named ``quantity``.

    The text as typed is read by the quantity's one reader (:mod:`twopose.values.bounds`: the
    grammar and the bound every other path applies), in ``--units`` when they were given
    (an eager option, read first), else in whichever unit takes it (the setup reads it
    again once the units are chosen). A count is passed on as an ``int``.
    """
    q: bounds.Quantity = getattr(bounds, quantity)
    count = q.kind is bounds.Kind.COUNT

    def parse(value: Any) -> Any:
        if not isinstance(value, str):  # a default
            return value
        try:
            return q.parse_text(value)
        except InputValueError as err:
            raise typer.BadParameter(str(err)) from None

    def in_units(ctx: typer.Context, value: Any) -> Any:
        if value is None or not hasattr(value, "text"):  # not given: its default
            return value
        units = ctx.params.get("units")
        try:
            v = q.read(value.text, Units(units) if units else None)
        except InputValueError as err:
            raise typer.BadParameter(str(err)) from None
        return int(v) if count else v

    lo, hi = q.limits(Units.IN)
    unit = q.unit_label(Units.IN)
    if q.kind is bounds.Kind.LENGTH:
        span = "length"
    elif count:
        span = f"{int(lo)}-{int(hi)}"
    else:  # a bound that refuses its low end itself shows it so: (0-100]
        span = f"{'(' if q.low_open else ''}{lo:g}-{hi:g}{']' if q.low_open else ''}"
        span += f" {unit}" if unit else ""
    return {"parser": parse, "callback": in_units, "metavar": f"<{span}>"}


def registered(
    registry: Registry[Any, Any],
    keep: Callable[[Any], bool] = lambda _entry: True,
    *,
    argument: bool = False,
) -> dict[str, Any]:
    """An option's (or, ``argument``, an argument's) parser and metavar: a registry's names.

    For ``typer.Option(**registered(METHOD_SPECS))``: the text given is the registered
    name it equals, read from the registry when the line is parsed (so an extension's
    entry is a choice too), else refused listing the names whose entry ``keep`` keeps (the
    metavar's; a name it leaves out is passed on, for the command to say why not).
    """
    load_extensions()  # an installed extension's entries are choices too

    def names() -> list[str]:
        return [n for n in registry.names if keep(registry[n])]

    def parse(value: Any) -> Any:
        if not isinstance(value, str) or isinstance(value, Name):  # a default, or read
            return value
        if value not in registry.names:  # one ``keep`` leaves out: the command says why
            raise typer.BadParameter(f"{value!r} is not one of {', '.join(names())}")
        return registry.key_of(value)

    listed = "|".join(names())
    return {"parser": parse, "metavar": listed if argument else f"<{listed}>"}
