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


def test_a_trial_no_pose_explains_names_no_axis() -> None:
    """A new user's r5 F5: "no single typed value explains it" beside `suspect_axis` z
    (the best component of all, named where no pose explained the trial)."""
    from twopose.uncertainty.blunders import trial_tests
    from twopose.uncertainty.misclosure import Misclosure

    N, M = 3, 6
    z = np.full((1, M), 5.0)  # chi2 150 on 6: no one component takes it below 5%
    bias = np.zeros((1, N, 3, M))
    for n in range(N):
        for c in range(2):
            bias[0, n, c, 2 * n + c] = 1.0  # each of x, y of each pose: one direction
    m = Misclosure(chi2=np.array([150.0]), dof=np.array([M]), placing_share=np.ones((1, M)),
                   z=z, bias=bias, iterations=np.ones(1, dtype=np.int_))  # fmt: skip
    tests = trial_tests(m, np.array([True]), np.array([1e-9]), 1.0)
    assert tests.explaining[0] == 0
    assert tests.axis[0] == ""  # the column agrees with the words
    assert tests.pose[0] == 0
    assert "no single typed value explains it" in tests.words(0, Units.IN, N)
