"""A trial tested against its own recorded truth (issue 54): beyond the chi-square's 0.1%
quantile on its region's dimensions it is flagged, kept out of the pool, its region not
widened (a region sized by its truth would cover it by construction); without a truth,
not tested."""

from __future__ import annotations

import dataclasses

import numpy as np
from scipy import special

from tests.helpers import load_benchmark
from twopose.methods.specs import Method
from twopose.methods.truth import reported
from twopose.solve.estimate import EstimateOptions
from twopose.solve.session import estimate_session
from twopose.uncertainty.blunders import TRUTH_LEVEL, TrialTests, truth_tests
from twopose.uncertainty.session_noise import session_statistics
from twopose.values.units import Units

bench = load_benchmark("bench_noise")


def test_the_cut_is_the_chi_squares_upper_quantile_on_the_regions_dimensions() -> None:
    cov = np.stack([np.eye(3), np.eye(3), np.diag([1.0, 0.0, 1.0]), np.eye(3)])
    cut3, cut2 = special.chdtri(3, TRUTH_LEVEL), special.chdtri(2, TRUTH_LEVEL)
    error = np.array([
        [np.sqrt(cut3) * 0.99, 0.0, 0.0],  # inside
        [0.0, 0.0, np.sqrt(cut3) * 1.01],  # beyond, along z
        [np.sqrt(cut2 / 2) * 1.01, 5.0, np.sqrt(cut2 / 2) * 1.01],  # a ground point: y left out
        [np.nan, np.nan, np.nan],  # no truth: not tested
    ])  # fmt: skip
    t = truth_tests(error, cov)
    assert t.flagged.tolist() == [False, True, True, False]
    assert t.dof.tolist() == [3, 3, 2, 0]
    assert t.axis.tolist() == [0, 2, -1, -1]
    assert np.isnan(t.p[3])
    assert np.isnan(t.off[3])


def test_a_flag_by_the_truth_widens_nothing_and_is_said_as_the_truth() -> None:
    tests = TrialTests.none(3)
    t = truth_tests(
        np.array([[0.1, 0, 0], [5.2, 0.1, 0.2], [0, 0, 0.3]]), np.stack([np.eye(3) * 0.13] * 3)
    )
    out = tests.with_truth(t)
    assert out.flagged.tolist() == [False, True, False]
    assert out.own.tolist() == [1.0, 1.0, 1.0]
    assert [out.by(i) for i in range(3)] == ["", "truth", ""]
    assert out.words(1, Units.IN, 3) == (
        "this trial's estimate lies 5.2 in (14 sigma), mostly in x from the grid point typed "
        "as its truth: one of its typed poses, the grid point, or the detection is off: check "
        "what you typed"
    )


def test_a_typed_grid_point_off_is_flagged_kept_out_of_the_pool_and_not_widened() -> None:
    trials = bench.apart(bench.session(Method.GROUND, 3, 4, 1.0))
    truth = trials.truth.copy()
    truth[2, :, 0] += 1.0  # trial 3's grid point typed 1 in off in x
    moved = dataclasses.replace(trials, truth=truth)
    clean = estimate_session(trials, EstimateOptions(), line_fits=False)
    est = estimate_session(moved, EstimateOptions(), line_fits=False)
    assert clean.tests is not None
    assert est.tests is not None
    assert est.factor is not None
    assert not clean.tests.flagged.any()
    assert [est.tests.by(i) for i in range(4)] == ["", "", "truth", ""]
    assert est.factor.flagged == 1
    assert est.factor.trials == 3  # kept out of the pool
    # the operator's pool keeps it: a first pass's regions are not settled yet, and a blunder
    # only its truth sees leaves its misclosure clean
    assert len(session_statistics("g", est.misclosure, est.tests).chi2) == 4
    assert est.tests.own[2] == 1.0  # not widened by its own misfit
    rep = reported(est)
    assert np.allclose(rep.point, reported(clean).point)  # the estimates as they were
    no_truth = dataclasses.replace(moved, truth=np.full_like(truth, np.nan))
    none = estimate_session(no_truth, EstimateOptions(), line_fits=False)
    assert none.tests is not None
    assert not none.tests.flagged.any()  # without a truth only the other tests apply


def test_a_trial_of_two_poses_is_tested_by_its_truth_alone_and_said_so_in_trials_csv() -> None:
    """Two poses: no misclosure to test, the truth still tests it (trials.csv's ``flagged``
    not empty for it, ``flagged_by`` ``truth``)."""
    from analysis.tables import noise as nc

    trials = bench.apart(bench.session(Method.GROUND, 4, 3, 1.0, 2))
    truth = trials.truth.copy()
    truth[0, :, 0] += 1.0
    truth[2] = np.nan  # no truth, no redundancy: nothing tests it
    est = estimate_session(dataclasses.replace(trials, truth=truth), EstimateOptions(),
                           line_fits=False)  # fmt: skip
    row = type("Row", (), {"estimate": est})()
    assert nc.flagged(row) == [True, False, None]
    assert nc.flagged_by(row) == ["truth", "", ""]
