"""The one table of bounds (twopose.values.bounds): its grammar, its message, its docs."""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest
from hypothesis import given
from hypothesis import strategies as st

from twopose.errors import InputValueError
from twopose.values.bounds import (
    FRAMES,
    GRID,
    GROUND_HEIGHT,
    MAX_POSES,
    POSE_TRANSLATION,
    QUANTITIES,
    REACH,
    ROTATION,
    TARGET_PRECISION,
    Kind,
    Quantity,
    shown,
)
from twopose.values.units import UNITS, Units

REPO = Path(__file__).resolve().parents[2]


@pytest.mark.parametrize(
    "text", ["1_0", "\u0661", "\uff15\uff12\uff15", "0x10", "inf", "nan", "1e", ".", "--1"]
)
@pytest.mark.parametrize("quantity", QUANTITIES, ids=lambda q: q.key)
def test_every_quantity_reads_only_ascii_numbers(quantity: Quantity, text: str) -> None:
    """Python's float takes 1_0, full-width and Arabic-Indic digits; no quantity does."""
    with pytest.raises(InputValueError, match=r"is not a (whole )?number"):
        quantity.read(text, Units.IN)


def test_a_number_past_a_float_is_refused_with_the_range_not_overflow() -> None:
    """``--reach 1e309`` was accepted and every accept then failed with OverflowError."""
    with pytest.raises(InputValueError) as caught:
        REACH.read("1e309", Units.IN)
    assert str(caught.value) == "reach must be from 0.0393701 to 100 in, got 1e309"
    with pytest.raises(InputValueError, match="got 100000000000"):
        REACH.read(10**400, Units.IN)  # an integer no float holds


def test_the_reach_and_the_grid_are_bounded_in_every_unit() -> None:
    """``--reach 1000`` took 115 s a suggestion; the bounds are 100 in and 1 mm, converted."""
    assert [REACH.limits(u)[1] for u in UNITS] == [100, 2540, 254, 2.54]
    assert [GRID.limits(u)[0] for u in UNITS] == [0.0393701, 1, 0.1, 0.001]
    for u in UNITS:
        with pytest.raises(InputValueError, match="reach must be"):
            REACH.read(REACH.limits(u)[1] * 1.01, u)
        assert REACH.read(REACH.limits(u)[1], u) == REACH.limits(u)[1]  # the bound shown


def test_counts_are_whole_and_bounded() -> None:
    assert MAX_POSES.count("6") == 6
    for bad in ("101", "1"):
        with pytest.raises(InputValueError, match="max poses must be a whole number from 2"):
            MAX_POSES.count(bad)
    for bad in ("2.5", "6.0", "1e1"):  # a count is written whole: one wording, every path
        with pytest.raises(InputValueError, match=f"max poses: '{bad}' is not a whole number"):
            MAX_POSES.count(bad)
    with pytest.raises(InputValueError, match=r"'5\.0' is not a whole number"):
        FRAMES.read(5.0, None)  # a plan's frames = 5.0
    with pytest.raises(InputValueError, match="must be a number, got True"):
        FRAMES.read(True, None)


def test_one_message_form() -> None:
    cases = {
        (GROUND_HEIGHT, "-3"): "ground height must be more than 0 and at most 200 in, got -3",
        (ROTATION, "181"): "rotation must be from -180 to 180 deg, got 181",
        (TARGET_PRECISION, "0"): "target precision must be more than 0 and at most 100 in, got 0",
    }
    for (quantity, text), message in cases.items():
        with pytest.raises(InputValueError) as caught:
            quantity.read(text, Units.IN)
        assert str(caught.value) == message
    with pytest.raises(InputValueError) as caught:
        POSE_TRANSLATION.read_vector("1, 2, 600", Units.CM)
    assert str(caught.value) == "camera centre z must be from -508 to 508 cm, got 600"
    # Units not known yet (a command line without --units): every unit's range.
    assert GROUND_HEIGHT.refusal(-3, None) == (
        "ground height must be more than 0 and at most 200 in (5080 mm, 508 cm, 5.08 m), got -3"
    )
    assert GROUND_HEIGHT.refusal(1000, None) == ""  # 1000 mm is a ground height


def test_a_plan_number_is_never_quoted() -> None:
    with pytest.raises(InputValueError, match="reach must be a number, got '3'"):
        REACH.read("3", Units.IN, text=False)


@given(st.floats(allow_nan=False, allow_infinity=False))
def test_a_value_shown_back_is_the_value_given(value: float) -> None:
    """``--focal 1234.56789`` reached the page as 1234.57 (``:g``)."""
    text = shown(value)
    assert float(text) == value
    assert not text.endswith(".0")


def test_shown_examples() -> None:
    assert [shown(v) for v in (1234.56789, 525.0, 1e-05, 5, -0.5)] == [
        "1234.56789",
        "525",
        "1e-05",
        "5",
        "-0.5",
    ]


def test_every_length_bound_is_one_length_in_inches() -> None:
    for q in QUANTITIES:
        if q.kind is not Kind.LENGTH:
            continue
        for u in UNITS:
            lo, hi = q.limits(u)
            factor = {Units.IN: 1, Units.MM: 25.4, Units.CM: 2.54, Units.M: 0.0254}[u]
            assert math.isclose(hi, q.high * factor, rel_tol=1e-5)
            assert math.isclose(lo, q.low * factor, rel_tol=1e-5, abs_tol=1e-12)


def test_the_docs_table_is_the_code_table() -> None:
    """docs/recording.md's table of bounds is what twopose.values.bounds states (regenerate it with
    ``.venv/bin/python docs/bounds_table.py --write-docs``)."""
    done = subprocess.run(
        [sys.executable, str(REPO / "docs" / "bounds_table.py")],
        capture_output=True,
        text=True,
        check=False,
    )
    assert done.returncode == 0, done.stdout
