"""twopose.units directly: one registry of units whose members are their symbols, and whose
sizes and limits agree with each other."""

from __future__ import annotations

import pytest

from twopose.errors import InputValueError
from twopose.units import UNIT_SPECS, UNITS, Units, unit_spec


def test_members_are_their_symbols_inches_first() -> None:
    assert UNITS[0] == "in"
    assert [str(u) for u in UNITS] == ["in", "mm", "cm", "m"]
    assert f"{Units.MM}" == "mm"
    assert unit_spec("cm") is UNIT_SPECS[Units.CM]
    assert unit_spec(Units.M).name == "metres"


@pytest.mark.parametrize("units", list(Units))
def test_limits_are_one_length_in_every_unit(units: Units) -> None:
    """The same physical limit in each unit (within the rounding the table chose)."""
    spec, inch = unit_spec(units), unit_spec("in")
    assert spec.units is units
    assert spec.max_translation * spec.inches == pytest.approx(inch.max_translation, rel=0.02)
    assert spec.ground_tolerance * spec.inches == pytest.approx(inch.ground_tolerance, rel=0.4)


def test_an_unknown_unit_lists_the_known_ones() -> None:
    with pytest.raises(InputValueError, match=r"units must be one of in, mm, cm, m, got 'ft'"):
        unit_spec("ft")
