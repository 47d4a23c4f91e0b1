"""Trials of one target tested against each other (issue 54): a typed value a trial's own
poses cannot check leaves its misclosure clean and moves its estimate by many sigmas; the
session's other trials of the same target see it."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tests.helpers import load_benchmark
from twopose.methods.specs import Method
from twopose.methods.truth import reported
from twopose.solve.estimate import EstimateOptions
from twopose.solve.session import estimate_session
from twopose.uncertainty.blunders import one_target, target_tests
from twopose.uncertainty.propagate import uncertainty_columns
from twopose.uncertainty.session_noise import session_statistics

bench = load_benchmark("bench_noise")


@pytest.mark.parametrize("method", [Method.POINT, Method.GROUND])
def test_a_blunder_its_misclosure_cannot_see_is_caught_by_the_other_trials(
    method: Method,
) -> None:
    """Seed 0: trial 2's pose 3 typed 1 in off in x, where its three poses cannot check it
    (its misclosure's p > 0.3); before, it went unflagged and its region missed the truth by
    about 5 in."""
    trials, which = bench.blundered(bench.session(method, 0, 4, 1.0), 0)
    assert (which > 0).tolist() == [False, True, False, False]
    est = estimate_session(trials, EstimateOptions(), line_fits=False)
    tests = est.tests
    assert tests is not None
    assert est.factor is not None
    assert tests.p[1] > 0.3  # the trial alone: nothing to see
    assert tests.flagged.tolist() == [False, True, False, False]
    assert est.factor.flagged == 1  # kept out of the pool
    assert est.factor.trials == 3
    words = tests.words(1, trials.units, 3)
    assert words.startswith("this trial's estimate lies about ")
    assert "other trials of the same target" in words
    assert "check what you typed" in words
    # three poses checked each other and agreed; two could not have (a new user's r8 F5)
    assert "where its poses agree:" in words
    assert "where its poses cannot check each other:" in tests.words(1, trials.units, 2)
    rep = reported(est)
    assert uncertainty_columns(rep.error, rep.cov)["within95"][1]  # widened by its own misfit
    # the operator's pool leaves it out as the session's does
    assert len(session_statistics("g", est.misclosure, tests).chi2) == 3


def test_trials_of_different_targets_are_not_compared() -> None:
    trials, _ = bench.blundered(bench.session(Method.POINT, 0, 4, 1.0), 0)
    truth = trials.truth.copy()
    truth[3] += 1.0  # the last trial measured another point: the session is no one target
    est = estimate_session(dataclasses.replace(trials, truth=truth), EstimateOptions(),
                           line_fits=False)  # fmt: skip
    assert est.tests is not None
    assert not any(est.tests.by(i) == "other trials" for i in range(4))
    # each trial against its own truth instead: the blind blunder, and the moved truth
    assert [est.tests.by(i) for i in range(4)] == ["", "truth", "", "truth"]


def test_one_target_reads_only_the_truths_equality() -> None:
    a = np.array([[1.0, 2.0, 3.0], [1.0, 2.0, 3.0]])
    same = np.stack([a] * 4)
    assert one_target(same).tolist() == [True] * 4
    unknown = same.copy()
    unknown[2] = np.nan
    assert one_target(unknown).tolist() == [True, True, False, True]
    assert not one_target(same[:2]).any()  # two trials: a disagreement names neither
    other = same.copy()
    other[0, :, 0] += 1e-3
    assert not one_target(other).any()


def test_the_worst_trial_first_and_two_others_at_least() -> None:
    point = np.zeros((4, 3))
    point[2, 0] = 10.0
    cov = np.stack([np.eye(3)] * 4)
    out = np.zeros(4, dtype=bool)
    t = target_tests(point, cov, np.ones(4, dtype=bool), out)
    assert t.flagged.tolist() == [False, False, True, False]
    assert t.dof.tolist() == [3, 3, 3, 3]
    assert t.apart[2] == pytest.approx(10.0)
    # a ground point's region (rank 2): the direction it says nothing about is left out
    flat = np.stack([np.diag([1.0, 0.0, 1.0])] * 4)
    off_plane = np.zeros((4, 3))
    off_plane[1, 1] = 50.0
    assert not target_tests(off_plane, flat, np.ones(4, dtype=bool), out).flagged.any()
    # three trials, one already kept out: two left, nothing to say which is off
    three = target_tests(point[:3], cov[:3], np.ones(3, dtype=bool), np.array([1, 0, 0], bool))
    assert not three.flagged.any()
    assert (three.dof[1:] == 0).all()


def test_a_trial_not_solved_beside_trials_of_one_target_is_left_out_not_a_crash() -> None:
    """A killed-and-recovered session's unfinished trial has no estimate (NaN point and
    covariance): the others are tested without it; it is neither tested nor flagged (its
    NaN region once went into an eigendecomposition: 'Eigenvalues did not converge')."""
    rng = np.random.default_rng(3)
    point = np.array([1.0, 9.6, 8.4]) + rng.normal(0.0, 0.01, (5, 3))
    cov = np.tile(np.diag([1e-4, 1e-4, 4e-4]), (5, 1, 1))
    point[2], cov[2] = np.nan, np.nan
    same = np.ones(5, dtype=bool)
    tests = target_tests(point, cov, same, np.zeros(5, dtype=bool))
    assert not tests.flagged.any()
    assert tests.dof[2] == 0
    assert np.isnan(tests.p[2])
    assert (tests.dof[[0, 1, 3, 4]] == 3).all()
