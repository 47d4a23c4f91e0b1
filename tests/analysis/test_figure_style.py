"""analysis.report.figures.style directly: one unit per figure (the sessions' own, or every length
in inches when they differ), a colour per trial (distinct steps up to 20), one per method."""

from __future__ import annotations

import pandas as pd
import pytest

from analysis.report.figures.style import TrialColours, common_units, method_colour
from twopose.methods.specs import MEASURING_METHODS, spec_of


def test_one_unit_per_figure() -> None:
    same = pd.DataFrame({"units": ["mm", "mm"], "err": [1.0, 2.0]})
    out, units = common_units(same)
    assert units == "mm"
    assert out is same
    mixed = pd.DataFrame(
        {"units": ["mm", "in", "cm"], "err": [25.4, 1.0, 2.54], "semiaxis95": [50.8, 2.0, 5.08]}
    )
    inches, units = common_units(mixed)
    assert units == "in"
    assert inches["err"].tolist() == pytest.approx([1.0, 1.0, 1.0])
    assert inches["semiaxis95"].tolist() == pytest.approx([2.0, 2.0, 2.0])
    assert mixed["err"].tolist() == [25.4, 1.0, 2.54]  # the caller's table is left alone
    assert common_units(pd.DataFrame({"err": [1.0]}))[1] == "session units"


def test_a_colour_per_trial() -> None:
    """TrialColours: distinct colours up to 20 trials, named up to 8, whatever the order
    or repeats of the numbers given; a trial it does not hold is grey."""
    palette = TrialColours.of([15, *range(1, 16), 3])
    assert palette.trials == tuple(range(1, 16))
    assert len({palette.colour(t) for t in range(1, 16)}) == 15
    assert not palette.named
    assert palette.colour(99) == (0.5, 0.5, 0.5, 1.0)
    few = TrialColours.of([2, 4, 6])
    assert few.named
    assert [h.get_label() for h in few.legend()] == ["trial 2", "trial 4", "trial 6"]
    many = TrialColours.of(range(1, 31))
    assert len({many.colour(t) for t in range(1, 31)}) == 30


def test_one_colour_per_method() -> None:
    colours = {method_colour(m) for m in MEASURING_METHODS}
    assert len(colours) == len(MEASURING_METHODS)
    assert all(method_colour(m) == spec_of(m).colour for m in MEASURING_METHODS)
