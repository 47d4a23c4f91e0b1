"""The session's length units as a type, with one registry.

Of what each one is: its size in inches (the thesis reports in inches), its name in words,
and the recorder's limits expressed in it. Every per-unit table reads it here.

``Units`` is a :class:`~enum.StrEnum`: its members equal, print and serialise as their
symbols (``Units.IN == "in"``), so files and tables are unchanged.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from types import MappingProxyType

from twopose.errors import InputValueError

__all__ = ["UNITS", "UNIT_SPECS", "UnitSpec", "Units", "unit_spec"]


class Units(StrEnum):
    """The unit of every length in a session (poses, ground height, truth, results)."""

    IN = "in"
    MM = "mm"
    CM = "cm"
    M = "m"


@dataclass(frozen=True, kw_only=True)
class UnitSpec:
    """One unit: its size, its name, and the recorder's limits in it."""

    units: Units
    inches: float  # inches in one unit
    name: str  # in words, plural ("inches")
    max_translation: float  # the largest typed translation a plan or the operator may give
    ground_tolerance: float  # how far off y = h a method 2 ground truth may lie unflagged


UNIT_SPECS: Mapping[Units, UnitSpec] = MappingProxyType(
    {
        Units.IN: UnitSpec(
            units=Units.IN, inches=1.0, name="inches", max_translation=200.0,
            ground_tolerance=1 / 32,
        ),
        Units.MM: UnitSpec(
            units=Units.MM, inches=1 / 25.4, name="millimetres", max_translation=5000.0,
            ground_tolerance=0.5,
        ),
        Units.CM: UnitSpec(
            units=Units.CM, inches=1 / 2.54, name="centimetres", max_translation=500.0,
            ground_tolerance=0.05,
        ),
        Units.M: UnitSpec(
            units=Units.M, inches=1000 / 25.4, name="metres", max_translation=5.0,
            ground_tolerance=0.0005,
        ),
    }
)  # fmt: skip
#: The units' symbols, inches first (the thesis' unit and the default).
UNITS: tuple[Units, ...] = tuple(UNIT_SPECS)


def unit_spec(units: str) -> UnitSpec:
    """The spec of ``units`` (a :class:`Units` or its symbol).

    An unknown one raises :class:`~twopose.errors.InputValueError` listing the known ones.
    """
    try:
        return UNIT_SPECS[Units(units)]
    except ValueError:
        raise InputValueError(f"units must be one of {', '.join(UNITS)}, got {units!r}") from None
