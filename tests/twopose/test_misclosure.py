"""The misclosure and the a-posteriori variance factor (issue 46): each trial's chi-square
against its own redundancy, pooled per session, the placing variance's multiplier measured
from it by variance component estimation, and the regions re-propagated only when the data
contradict the typed placing sigma. Seeded geometric sessions (benchmarks/bench_sigma0.py's)."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tests.helpers import load_benchmark
from twopose.estimate import EstimateOptions
from twopose.methods import Method
from twopose.misclosure import misclosures, placing_component, pooled
from twopose.noise import NoiseModel, PlacingSigma, VarianceFactor
from twopose.session_estimate import (
    SessionTrials,
    estimate_session,
    placing_sigmas,
    placing_source,
)
from twopose.uncertainty import region_dof
from twopose.units import Units

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


def _placed_at(sigma_in: float) -> EstimateOptions:
    """No test, every pose's placing sigma ``sigma_in``: the re-propagation by hand."""
    return EstimateOptions(
        noise=NoiseModel(placing=PlacingSigma(sigma_in=sigma_in), test_redundancy=False)
    )


def _expected(trials: SessionTrials, factor: VarianceFactor) -> np.ndarray:
    """Every ok trial's region propagated with the placing sigma x sqrt(lambda), then F."""
    again = estimate_session(trials, _placed_at(TYPED * math.sqrt(factor.placing_variance)))
    ok = again.estimates.status == "ok"
    scale = np.array([factor.widening(int(d)) for d in region_dof(again.estimates.cov[ok])])
    return np.asarray(again.estimates.cov[ok] * scale[:, None, None])


def test_a_session_placed_worse_than_typed_is_measured_and_repropagated() -> None:
    trials = bench.session(Method.POINT, 3, 2.5 * TYPED, 15)
    tested, plain = estimate_session(trials, EstimateOptions()), estimate_session(trials, PLAIN)
    factor = tested.factor
    assert factor is not None
    assert factor.contradicted
    # lambda = 2.5^2 = 6.25 simulated; estimated within its own ~sqrt(2 / f) spread
    assert 4.0 < factor.placing_variance < 9.0, factor.placing_variance
    assert factor.placing_dof > 40
    ok = tested.estimates.status == "ok"
    # re-propagated with the placing sigma x sqrt(lambda), not one factor on every input:
    # the steps of the differences scale with the sigma, so to the differences' precision
    np.testing.assert_allclose(tested.estimates.cov[ok], _expected(trials, factor), rtol=1e-5)
    widening = tested.estimates.widening[ok]
    assert (widening > 1.5).all()
    # the calibration's shared part is not scaled: less than lambda times the F quantile
    assert (widening < factor.placing_variance * factor.widening(3)).all()
    np.testing.assert_array_equal(tested.estimates.point, plain.estimates.point)
    assert (placing_sigmas(trials, tested.options, factor) > 2 * TYPED).all()
    assert placing_source(tested.options, factor) == "measured by the session's redundancy"


def test_a_session_placed_as_typed_is_not_widened() -> None:
    trials = bench.session(Method.POINT, 1, TYPED, 15)
    tested, plain = estimate_session(trials, EstimateOptions()), estimate_session(trials, PLAIN)
    assert tested.factor is not None
    assert tested.factor.tested
    assert tested.factor.estimated
    assert not tested.factor.contradicted
    assert tested.factor.placing_variance == 1.0
    np.testing.assert_array_equal(tested.estimates.cov, plain.estimates.cov)
    ok = tested.estimates.status == "ok"
    assert (tested.estimates.widening[ok] == 1.0).all()
    assert placing_source(tested.options, tested.factor) == "typed"
    assert plain.factor is None
    assert plain.misclosure is None


def test_a_factor_given_is_applied_as_is_never_estimated() -> None:
    trials = bench.session(Method.GROUND, 2, TYPED, 6)
    # from sigma0 alone (no variance components): all of the misfit is the placing's
    given = VarianceFactor(sigma0_sq=4.0, dof=30, trials=6)
    options = EstimateOptions(noise=NoiseModel(factor=given))
    est = estimate_session(trials, options)
    assert est.factor is given
    assert est.misclosure is None
    assert given.placing_variance == 4.0
    ok = est.estimates.status == "ok"
    assert (region_dof(est.estimates.cov[ok]) == 2).all()  # a ground point's region
    np.testing.assert_allclose(est.estimates.cov[ok], _expected(trials, given), rtol=1e-5)


@pytest.mark.parametrize("lam", [1.0, 2.56, 0.5])
def test_placing_component_recovers_lambda_and_its_dof(lam: float) -> None:
    rng = np.random.default_rng(7)
    beta = rng.uniform(0.0, 1.0, 4000)
    z2 = (1 + (lam - 1) * beta) * rng.standard_normal(beta.size) ** 2
    estimate, lr, f = placing_component(beta, z2)
    # sqrt(2 / f): the estimate's relative 1-sigma
    assert abs(estimate / lam - 1) < 3 * math.sqrt(2 / f), (estimate, f)
    assert f == pytest.approx(((estimate * beta / (1 + (estimate - 1) * beta)) ** 2).sum())
    if lam == 1.0:
        assert lr < 6.6  # chi-square 1 dof's 99%
    else:
        assert lr > 20
    # no placing direction: nothing to estimate
    assert all(math.isnan(v) for v in placing_component(np.zeros(3), np.ones(3)))


def test_the_test_is_one_sided_and_says_the_measured_sigma() -> None:
    larger = VarianceFactor(sigma0_sq=1.5, dof=40, trials=10, placing_scale=1.6,
                            placing_dof=30.0, placing_lr=12.0)  # fmt: skip
    smaller = dataclasses.replace(larger, placing_scale=0.6)
    weak = dataclasses.replace(larger, placing_lr=2.0)
    assert larger.contradicted
    assert not smaller.contradicted  # a careful operator never narrows the regions
    assert not weak.contradicted
    assert larger.placing_variance == pytest.approx(2.56)
    assert larger.widening(3) > 1.0
    assert smaller.widening(3) == weak.widening(3) == 1.0
    said = larger.describe(0.0625, Units.IN)
    assert "measures the placing sigma at 0.1 in (1.6x the assumed 0.0625 in)" in said


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


def test_the_words_say_a_sigma0_far_below_one_and_never_call_a_measured_sigma_typed() -> None:
    """Adversary, issue 46: sigma0 0.62 on 24 dof was said to agree (its regions about
    1.8x too wide), and a board-measured sigma contradicted was called "typed"."""
    from twopose.noise import noise_words

    assert "scatter less than the noise model says" in noise_words(0.62, 24, 1.0)
    assert noise_words(1.05, 24, 1.0).endswith("the data agree with the noise model")
    said = noise_words(1.6, 24, 1.8, placing_scale=1.6)
    assert "typed" not in said
    assert "largest semi-axis widened x1.8" in said
