"""A flagged trial's words (issue 54): a size is said only for one typed axis. A new
user's method-2 trials from three poses, one pose's x typed 1 in off, read "one of them
looks about 1 to 1062 in off": the poses that could explain a two-dof misclosure each did
so in another axis, their sizes of different things."""

from __future__ import annotations

import dataclasses

import numpy as np

from twopose.uncertainty.blunders import TrialTests
from twopose.values.units import Units


def _flagged(axis: str, spread: tuple[float, float], explaining: int) -> TrialTests:
    none = TrialTests.none(1)
    return dataclasses.replace(
        none, flagged=np.array([True]), axis=np.array([axis], dtype="<U1"),
        spread=np.array([spread]), explaining=np.array([explaining]),
    )  # fmt: skip


def test_explanations_in_other_axes_say_no_size() -> None:
    said = _flagged("", (1.0, 1062.0), 3).words(0, Units.IN, 3)
    assert said == (
        "this trial's poses disagree (one typed value looks off, but which, and by how much, "
        "3 poses cannot tell): check what you typed, or add a fourth pose"
    )
    assert "1062" not in said
    assert "another pose" in _flagged("", (10.0, 18.0), 2).words(0, Units.CM, 4)


def test_explanations_in_one_axis_say_it_and_their_sizes() -> None:
    said = _flagged("x", (1.0, 4.0), 3).words(0, Units.IN, 3)
    assert said == (
        "this trial's poses disagree (typed x of one of them looks about 1 to 4 in off): "
        "check what you typed, or add a fourth pose"
    )
