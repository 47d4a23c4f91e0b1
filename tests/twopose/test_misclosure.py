"""The misclosure and the a-posteriori variance factor (issue 46): each trial's chi-square
against its own redundancy, pooled per session, and the regions widened only when the data
contradict the noise model. Seeded geometric sessions (benchmarks/bench_sigma0.py's)."""

from __future__ import annotations

import dataclasses

import numpy as np
import pytest

from tests.helpers import load_benchmark
from twopose.estimate import EstimateOptions
from twopose.methods import Method
from twopose.misclosure import misclosures, pooled
from twopose.noise import NoiseModel, VarianceFactor
from twopose.session_estimate import estimate_session, widening_of
from twopose.uncertainty import region_dof

bench = load_benchmark("bench_sigma0")
TYPED = bench.TYPED_IN
PLAIN = EstimateOptions(noise=NoiseModel(test_redundancy=False))


@pytest.mark.parametrize("method", [Method.POINT, Method.LINE])
def test_misclosure_chi2_follows_its_dof_under_the_right_model(method: Method) -> None:
    chi2, dof = [], []
    for seed in range(4):
        m = estimate_session(bench.session(method, seed, TYPED, 10), EstimateOptions()).misclosure
        assert m is not None
        use = m.dof > 0
        chi2 += list(m.chi2[use])
        dof += list(m.dof[use])
    ratio = sum(chi2) / sum(dof)
    # sum(dof) ~ 160-200: sigma0^2's standard error is sqrt(2 / dof) ~ 0.11
    assert 0.75 < ratio < 1.3, ratio
    # each trial's dof: 2N - 3 for a point, 2N - 4 for a line
    parameters = 3 if method is Method.POINT else 4
    assert set(dof) <= {2 * n - parameters for n in (3, 4, 5)}


def test_a_session_placed_worse_than_typed_is_contradicted_and_widened() -> None:
    trials = bench.session(Method.POINT, 3, 2.5 * TYPED, 15)
    tested, plain = estimate_session(trials, EstimateOptions()), estimate_session(trials, PLAIN)
    factor = tested.factor
    assert factor is not None
    assert factor.contradicted
    assert factor.sigma0_sq > 3.0
    ok = tested.estimates.status == "ok"
    k = region_dof(plain.estimates.cov[ok])
    scale = np.array([factor.widening(int(d)) for d in k])
    expected = plain.estimates.cov[ok] * scale[:, None, None]
    np.testing.assert_allclose(tested.estimates.cov[ok], expected, rtol=1e-9)
    assert (widening_of(tested.estimates.cov[ok], factor) > factor.sigma0_sq).all()
    np.testing.assert_array_equal(tested.estimates.point, plain.estimates.point)


def test_a_session_placed_as_typed_is_not_widened() -> None:
    trials = bench.session(Method.POINT, 1, TYPED, 15)
    tested, plain = estimate_session(trials, EstimateOptions()), estimate_session(trials, PLAIN)
    assert tested.factor is not None
    assert tested.factor.tested
    assert not tested.factor.contradicted
    np.testing.assert_array_equal(tested.estimates.cov, plain.estimates.cov)
    assert plain.factor is None
    assert plain.misclosure is None


def test_a_factor_given_is_applied_as_is_never_estimated() -> None:
    trials = bench.session(Method.GROUND, 2, TYPED, 6)
    given = VarianceFactor(sigma0_sq=4.0, dof=30, trials=6)
    options = EstimateOptions(noise=NoiseModel(factor=given))
    est, plain = estimate_session(trials, options), estimate_session(trials, PLAIN)
    assert est.factor is given
    assert est.misclosure is None
    ok = est.estimates.status == "ok"
    assert (region_dof(est.estimates.cov[ok]) == 2).all()  # a ground point's region
    np.testing.assert_allclose(
        est.estimates.cov[ok], plain.estimates.cov[ok] * given.widening(2), rtol=1e-9
    )


def test_two_pose_line_trials_carry_no_redundancy() -> None:
    trials = bench.session(Method.LINE, 4, 2.5 * TYPED, 6, poses=(2, 2))
    est = estimate_session(trials, EstimateOptions())
    assert est.misclosure is not None
    assert (est.misclosure.dof == 0).all()
    assert est.factor is not None
    assert not est.factor.tested
    assert not est.factor.contradicted
    np.testing.assert_array_equal(est.estimates.cov, estimate_session(trials, PLAIN).estimates.cov)


def test_method2s_misclosure_is_its_planes_line_s() -> None:
    line = bench.session(Method.LINE, 5, TYPED, 4)
    ground = dataclasses.replace(line, method=Method.GROUND, ground=(np.array([0, 1.0, 0]), 9.625))
    a = estimate_session(line, EstimateOptions()).misclosure
    b = estimate_session(ground, EstimateOptions()).misclosure
    assert a is not None
    assert b is not None
    np.testing.assert_allclose(a.chi2, b.chi2)
    np.testing.assert_array_equal(a.dof, b.dof)


def test_inputs_the_model_takes_as_exact_test_nothing() -> None:
    # no noise anywhere: no direction of the residuals to test (not chi2 0 on 3 dof)
    T, N = 2, 3
    zero = np.zeros((T, N, 9))
    m = misclosures(lambda x: np.zeros((x.shape[0], N, 2)), zero, np.zeros((T, N, 9, 9)),
                    np.ones((T, N), dtype=bool), 3)  # fmt: skip
    assert (m.dof == 0).all()
    assert np.isnan(m.chi2).all()
    assert not pooled(m).tested
