"""The session's length units as a type, with one registry.

Of what each one is: its size in inches (the thesis reports in inches), its name in words,
and the ground tolerance in it. Every per-unit table reads it here; the bounds of typed
values, stated in inches and converted, are :mod:`twopose.values.bounds`'.

``Units`` is a :class:`~enum.StrEnum`: its members equal, print and serialise as their
symbols (``Units.IN == "in"``), so files and tables are unchanged.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from types import MappingProxyType
from typing import Any, TypeVar

from twopose.errors import InputValueError

__all__ = [
    "DEFAULT_UNITS",
    "IS_LENGTH",
    "LENGTH",
    "UNITS",
    "UNIT_SPECS",
    "UnitSpec",
    "Units",
    "length_values",
    "scale_lengths",
    "unit_factor",
    "unit_spec",
]

T = TypeVar("T")


class Units(StrEnum):
    """The unit of every length in a session (poses, ground height, truth, results)."""

    IN = "in"
    MM = "mm"
    CM = "cm"
    M = "m"


@dataclass(frozen=True, kw_only=True)
class UnitSpec:
    """One unit: its size, its name, and the ground tolerance in it."""

    #: The unit's symbol (its key in :data:`UNIT_SPECS`).
    units: Units
    #: Inches in one unit.
    inches: float
    #: The unit in words, plural ("inches").
    name: str
    #: How far off y = h a method 2 ground truth may lie unflagged, in this unit.
    ground_tolerance: float


#: The unit registry: each unit's :class:`UnitSpec`, inches first. Every rule that depends
#: on the units reads it here.
UNIT_SPECS: Mapping[Units, UnitSpec] = MappingProxyType(
    {
        Units.IN: UnitSpec(
            units=Units.IN, inches=1.0, name="inches",
            ground_tolerance=1 / 32,
        ),
        Units.MM: UnitSpec(
            units=Units.MM, inches=1 / 25.4, name="millimetres",
            ground_tolerance=0.5,
        ),
        Units.CM: UnitSpec(
            units=Units.CM, inches=1 / 2.54, name="centimetres",
            ground_tolerance=0.05,
        ),
        Units.M: UnitSpec(
            units=Units.M, inches=1000 / 25.4, name="metres",
            ground_tolerance=0.0005,
        ),
    }
)  # fmt: skip
#: The units' symbols, inches first (the thesis' unit and the default).
UNITS: tuple[Units, ...] = tuple(UNIT_SPECS)
#: The thesis' unit, a session's when none is given: the registry's first (inches).
DEFAULT_UNITS: Units = UNITS[0]


def unit_spec(units: str) -> UnitSpec:
    """The spec of ``units`` (a :class:`Units` or its symbol).

    An unknown one raises :class:`~twopose.errors.InputValueError` listing the known ones.
    """
    try:
        return UNIT_SPECS[Units(units)]
    except ValueError:
        raise InputValueError(f"units must be one of {', '.join(UNITS)}, got {units!r}") from None


def unit_factor(from_units: str, to_units: str) -> float:
    """How many ``to_units`` make one ``from_units`` (``unit_factor("in", "cm") == 2.54``)."""
    return unit_spec(from_units).inches / unit_spec(to_units).inches


# --------------------------------------------------------------------------- lengths

#: The metadata key that marks a dataclass field as a length (a float or a tuple of
#: floats in its object's units): the one registry of which numbers a change of units
#: scales. Angles, pixels, colours and counts are not marked.
LENGTH = "twopose.length"


#: A length field's metadata: ``x: float = field(default=1.0, metadata=IS_LENGTH)``.
IS_LENGTH: Mapping[str, bool] = MappingProxyType({LENGTH: True})


def scale_lengths(obj: T, factor: float) -> T:
    """``obj`` (a frozen dataclass) with every length field times ``factor``.

    Recursively, through fields holding dataclasses or tuples of them; everything not
    marked by :data:`IS_LENGTH` is kept as it is.
    """
    changes: dict[str, Any] = {}
    for f in dataclasses.fields(obj):  # type: ignore[arg-type]
        value = getattr(obj, f.name)
        if f.metadata.get(LENGTH):
            changes[f.name] = _scaled(value, factor)
        elif dataclasses.is_dataclass(value) and not isinstance(value, type):
            changes[f.name] = scale_lengths(value, factor)
        elif isinstance(value, tuple) and value and dataclasses.is_dataclass(value[0]):
            changes[f.name] = tuple(scale_lengths(v, factor) for v in value)
    return dataclasses.replace(obj, **changes)  # type: ignore[type-var]


def _scaled(value: Any, factor: float) -> Any:
    if isinstance(value, tuple):
        return tuple(float(v) * factor for v in value)
    return float(value) * factor


def length_values(obj: Any) -> dict[str, Any]:
    """The length fields of ``obj`` (a dataclass), nested as a table of its file would be.

    Fields holding one dataclass recurse; tuples of dataclasses (a list of tables) are left
    out: a file that gives such a list gives it whole.
    """
    found: dict[str, Any] = {}
    for f in dataclasses.fields(obj):
        value = getattr(obj, f.name)
        if f.metadata.get(LENGTH):
            found[f.name] = list(value) if isinstance(value, tuple) else value
        elif dataclasses.is_dataclass(value) and not isinstance(value, type):
            nested = length_values(value)
            if nested:
                found[f.name] = nested
    return found
