"""analysis.figure_style directly: one unit per figure (the sessions' own, or every length
in inches when they differ), a colour per trial (distinct steps up to 20), one per method."""

from __future__ import annotations

import pandas as pd
import pytest
from matplotlib.colors import BoundaryNorm, Normalize

from analysis.figure_style import common_units, method_colour, trial_colours


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
    cmap, norm = trial_colours(list(range(1, 16)))
    assert isinstance(norm, BoundaryNorm)  # distinct steps: one colour per trial
    colours = {tuple(cmap(norm(t))) for t in range(1, 16)}
    assert len(colours) == 15
    _, ramp = trial_colours(list(range(1, 31)))
    assert type(ramp) is Normalize
    assert (ramp.vmin, ramp.vmax) == (1, 30)


def test_one_colour_per_method() -> None:
    colours = {method_colour(m) for m in ("point", "line", "ground")}
    assert len(colours) == 3
    assert method_colour("something else") == "C4"
