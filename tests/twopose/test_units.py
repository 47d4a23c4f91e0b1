"""twopose.values.units directly: one registry of units whose members are their symbols, and whose
sizes and limits agree with each other."""

from __future__ import annotations

import pytest

from twopose.errors import InputValueError
from twopose.values.bounds import POSE_TRANSLATION
from twopose.values.units import UNIT_SPECS, UNITS, Units, unit_spec


def test_members_are_their_symbols_inches_first() -> None:
    assert UNITS[0] == "in"
    assert [str(u) for u in UNITS] == ["in", "mm", "cm", "m"]
    assert f"{Units.MM}" == "mm"
    assert unit_spec("cm") is UNIT_SPECS[Units.CM]
    assert unit_spec(Units.M).name == "metres"


#: The finest tick of the tape each unit is measured with: 1/16 in, or 1 mm.
TAPE_TICK_MM = {Units.IN: 25.4 / 16, Units.MM: 1.0, Units.CM: 1.0, Units.M: 1.0}


@pytest.mark.parametrize("units", list(Units))
def test_limits_are_one_length_in_every_unit(units: Units) -> None:
    """The largest typed position is the same length in every unit (200 in, converted and
    shown to six digits); the ground tolerance is exactly half the finest tick of the
    unit's tape (1/32 in, 0.5 mm), not "about" a length."""
    spec, inch = unit_spec(units), unit_spec("in")
    assert spec.units is units
    high = POSE_TRANSLATION.limits(units)[1]
    assert high * spec.inches == pytest.approx(POSE_TRANSLATION.limits(Units.IN)[1], rel=1e-6)
    assert inch.inches == 1.0
    tolerance_mm = spec.ground_tolerance * spec.inches * 25.4
    assert tolerance_mm == pytest.approx(TAPE_TICK_MM[units] / 2, rel=1e-12)


def test_an_unknown_unit_lists_the_known_ones() -> None:
    with pytest.raises(InputValueError, match=r"units must be one of in, mm, cm, m, got 'ft'"):
        unit_spec("ft")
