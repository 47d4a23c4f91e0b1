"""The placing variance's multiplier (issue 54): always estimated (no pretest), its
posterior the conjugate one where the data are all placing, a minimum-dof guard, no grid
cap hit silently; trials whose poses disagree flagged before pooling (Baarda), robustly;
the operator's other sessions as each session's prior."""

from __future__ import annotations

import math

import numpy as np
import pytest

from tests.helpers import load_benchmark
from twopose.methods.specs import Method
from twopose.solve.estimate import EstimateOptions
from twopose.solve.session import estimate_session
from twopose.uncertainty.noise import NoiseModel, PlacingPrior
from twopose.uncertainty.operator_pool import SessionNoise, operator_priors
from twopose.uncertainty.placing_variance import (
    GRID,
    posterior,
    trial_information,
    trial_loglik,
)
from twopose.uncertainty.robust_flags import flag_trials

bench = load_benchmark("bench_noise")
TYPED = PlacingPrior(scale=1.0, dof=2.0, source="the typed resolution")


def _trials(
    lam: float, n: int, m: int, rng: np.random.Generator, beta: float = 1.0
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """``n`` trials of ``m`` directions, each ``beta`` placing, drawn at multiplier ``lam``."""
    share = np.full((n, m), beta)
    z2 = (1 + (lam - 1) * share) * rng.standard_normal((n, m)) ** 2
    return z2.sum(axis=1), np.full(n, m), share, z2


def test_the_posterior_is_the_conjugate_one_where_the_data_are_all_placing() -> None:
    rng = np.random.default_rng(1)
    _, _, share, z2 = _trials(2.5, 6, 3, rng)
    post = posterior(trial_loglik(share, z2).sum(axis=0), TYPED, None,
                     trial_information(share).sum(axis=0))  # fmt: skip
    # scaled inverse chi-square: (nu0 s0 + sum z^2) / (nu0 + n) on nu0 + n
    n = z2.size
    assert post.dof == pytest.approx(2.0 + n, rel=0.02)
    assert post.scale == pytest.approx((2.0 + z2.sum()) / (2.0 + n), rel=0.02)
    assert post.information == pytest.approx(n, rel=0.01)
    with_prior = posterior(trial_loglik(share, z2).sum(axis=0), TYPED,
                           PlacingPrior(scale=4.0, dof=30.0, source="x"))  # fmt: skip
    assert with_prior.dof == pytest.approx(32.0 + n, rel=0.02)  # the prior is data
    assert with_prior.scale == pytest.approx((2.0 + 120.0 + z2.sum()) / (32.0 + n), rel=0.02)


def test_no_pretest_the_multiplier_is_used_where_sigma0s_test_does_not_reject() -> None:
    """Issue 54: lambda was taken as exactly 1 unless a 5% test rejected (a pretest
    estimator: sessions that did not reject covered 60-77%). Now the session's estimate is
    used whatever the test says, with the F quantile for its degrees of freedom."""
    trials = bench.session(Method.POINT, 13, 2, 1.6)
    est = estimate_session(trials, EstimateOptions())
    factor = est.factor
    assert factor is not None
    assert not factor.contradicted  # sigma0's test alone would have kept the typed sigma
    assert factor.estimated
    assert factor.p_upper == pytest.approx(0.10, abs=0.01)
    assert factor.placing_variance > 1.5
    ok = est.estimates.status == "ok"
    assert (est.estimates.widening[ok] > 1.5).all()  # lambda and its F quantile (8 dof)


def test_the_minimum_dof_guard_and_the_grid_limit_are_said() -> None:
    rng = np.random.default_rng(2)
    _, _, share, z2 = _trials(1.0, 1, 2, rng)  # 2 dof beside the anchor: below the guard
    post = posterior(trial_loglik(share, z2).sum(axis=0), TYPED, None,
                     trial_information(share).sum(axis=0))  # fmt: skip
    assert round(post.information) < 3
    # a multiplier beyond the grid (a placing sigma 3000x the typed): at its limit, said
    huge = posterior(trial_loglik(np.ones((1, 40)), np.full((1, 40), 5e6)).sum(axis=0), TYPED)
    assert huge.at_limit
    assert huge.scale > GRID[-40]
    fine = posterior(trial_loglik(*_trials(9.0, 10, 3, rng)[2:]).sum(axis=0), TYPED)
    assert not fine.at_limit


def test_a_blunder_is_flagged_and_a_careless_operators_trials_are_not() -> None:
    rng = np.random.default_rng(3)
    chi2, dof, share, z2 = _trials(1.0, 12, 3, rng)
    z2[4] += np.array([40.0, 0.0, 0.0])  # one trial's poses disagree
    chi2 = z2.sum(axis=1)
    flags = flag_trials(chi2, dof, share, z2, TYPED)
    assert flags.flagged.tolist() == [i == 4 for i in range(12)]
    assert flags.p[4] < 0.01
    assert (flags.kept[4] == 0).all()  # kept out of the pool
    # every trial 3x worse than typed: they disagree with the typed model, not each other
    chi2, dof, share, z2 = _trials(9.0, 12, 3, rng)
    assert not flag_trials(chi2, dof, share, z2, TYPED).flagged.any()
    # one trial alone, nothing beside it: the typed test decides
    lone = flag_trials(chi2[:1] * 0 + 60.0, dof[:1], share[:1], z2[:1] * 0 + 20.0, TYPED)
    assert lone.flagged.all()


def test_many_blunders_cannot_hide_each_other() -> None:
    """Masking: with a third of the trials blundered, a rest that held them all would
    widen until none was flagged; the search starts from the half that fit best."""
    rng = np.random.default_rng(4)
    chi2, dof, share, z2 = _trials(1.0, 30, 3, rng)
    bad = np.arange(30) % 3 == 0
    z2[bad, 0] += 60.0
    chi2 = z2.sum(axis=1)
    flagged = flag_trials(chi2, dof, share, z2, TYPED).flagged
    assert flagged[bad].all()
    assert not flagged[~bad].any()


def _session(group: str, lam: float, seed: int, n: int = 4) -> SessionNoise:
    chi2, dof, share, z2 = _trials(lam, n, 3, np.random.default_rng(seed), beta=0.9)
    return SessionNoise(group=group, chi2=chi2, dof=dof, share=share, z2=z2)


def test_each_session_gets_its_operators_other_sessions_as_its_prior() -> None:
    sessions = [_session("alice (point)", 2.56, s) for s in range(20)]
    sessions += [_session("bob (point)", 1.0, 100 + s, n=10) for s in range(3)]
    sessions += [_session("", 9.0, 200), _session("carol (point)", 1.0, 300)]
    priors = operator_priors(sessions, TYPED)
    for p in priors[:20]:
        assert p is not None
        assert p.source == "19 other sessions of operator alice (point)"
        assert 1.9 < p.scale < 3.4
        assert p.dof > 10  # the spread between sessions, by type II maximum likelihood
    assert all(p is not None and p.scale < 1.6 for p in priors[20:23])
    assert priors[23] is None  # no operator named: alone
    assert priors[24] is None  # the only one of its operator


def test_an_operator_whose_sessions_differ_is_pooled_less() -> None:
    same = [_session("a", 2.0, s, n=6) for s in range(12)]
    mixed = [_session("a", lam, s, n=6) for s, lam in enumerate([0.3, 6.0] * 6)]
    p_same, p_mixed = operator_priors(same, TYPED)[0], operator_priors(mixed, TYPED)[0]
    assert p_same is not None
    assert p_mixed is not None
    assert p_mixed.dof < p_same.dof / 4
    assert math.isfinite(p_mixed.dof)


def test_a_blundered_trial_is_kept_out_of_the_operators_pool() -> None:
    sessions = [_session("a", 1.0, s) for s in range(10)]
    blunder = sessions[3]
    z2 = blunder.z2.copy()
    z2[0, 0] += 400.0
    sessions[3] = SessionNoise(group="a", chi2=z2.sum(axis=1), dof=blunder.dof,
                               share=blunder.share, z2=z2)  # fmt: skip
    prior = operator_priors(sessions, TYPED)[0]
    assert prior is not None
    assert prior.scale < 1.4  # with it the pool would say ~4
    assert NoiseModel(prior=prior).prior is prior


def test_the_pooled_multiplier_is_unbiased_over_many_seeded_draws() -> None:
    """Issue 54: the pooled maximum-likelihood multiplier, after the robust test kept the
    trials it keeps (its truncation of the chi-square's upper tail corrected by each kept
    trial's chance of being kept), is unbiased: over many seeded draws of 40 trials of 3
    redundant directions with mixed placing shares, its mean lies within three standard
    errors of the truth (about 1.7% each; 1.025 at 1, 1.012 at 9). The misclosure's space
    has the trial's redundancy as its dimension, so maximum likelihood there is already the
    restricted (REML) estimate: no dof is lost to the parameters. A guard, not a fix: the
    estimator was found unbiased (docs/uncertainty.md), and dropping the truncation's
    correction moves it less than its standard error here (at 0.5% the robust test keeps
    nearly every clean trial)."""
    from twopose.uncertainty.noise import PlacingPrior
    from twopose.uncertainty.operator_pool import _maximum

    rng = np.random.default_rng(54)
    anchor = PlacingPrior(scale=1.0, dof=2.0, source="typed")
    for lam in (1.0, 9.0):
        ratios = []
        for _ in range(120):
            share = rng.uniform(0.2, 1.0, (40, 3))
            z2 = (1 + (lam - 1) * share) * rng.standard_normal((40, 3)) ** 2
            flags = flag_trials(z2.sum(axis=1), np.full(40, 3), share, z2, anchor)
            ratios.append(_maximum(flags.kept.sum(axis=0)) / lam)
        mean, se = np.mean(ratios), np.std(ratios) / np.sqrt(len(ratios))
        assert abs(mean - 1.0) < 3 * se, (lam, mean, se)


def _mostly_pixels(chi2: float, z2: list[float], share: list[float]) -> SessionNoise:
    return SessionNoise(group="eve (point)", chi2=np.array([chi2]), dof=np.array([5]),
                        share=np.array([share]), z2=np.array([z2]))  # fmt: skip


def test_a_blunder_in_directions_mostly_of_pixels_is_flagged_beside_trials_that_know_little() -> (
    None
):
    """Issue 54's F1 (a new user's three one-trial sessions of one operator): the typed
    x of one pose 1 in off gave a chi-square of 48 on 5 dof in directions each a fifth
    placing, beside two trials that scatter less than typed. Fisher's F let the rest's
    uncertainty scale the pixels too (p 0.008 > 0.005): the blunder was not flagged, fed
    the other two sessions' prior and widened them 1.8x. The posterior predictive flags
    it, and the clean sessions pool nothing from it."""
    blunder = _mostly_pixels(
        48.12, [0.0183, 1.289, 28.05, 17.87, 0.888], [0.193, 0.215, 0.216, 0.243, 0.252]
    )
    clean = _mostly_pixels(
        0.0625, [0.0085, 0.0081, 0.0395, 0.0036, 0.0028], [0.235, 0.262, 0.264, 0.309, 0.312]
    )
    stats = [blunder, clean, clean]
    chi2 = np.concatenate([s.chi2 for s in stats])
    dof = np.concatenate([s.dof for s in stats])
    share = np.concatenate([s.share for s in stats])
    z2 = np.concatenate([s.z2 for s in stats])
    flags = flag_trials(chi2, dof, share, z2, TYPED)
    assert flags.flagged.tolist() == [True, False, False]
    assert flags.p[0] < 1e-4
    # the clean sessions' prior is the other clean one alone: too little to estimate from
    assert operator_priors(stats, TYPED) == [None, None, None]


@pytest.mark.parametrize("lam", [1.0, 3.0])
def test_clean_trials_of_any_placing_share_are_rarely_flagged(lam: float) -> None:
    """The test against the rest at Baarda's 0.5% keeps its false alarms near that level
    over trials whose directions are anything from a twentieth to all placing."""
    rng = np.random.default_rng(int(lam * 10))
    flagged = total = 0
    for _ in range(60):
        share = rng.uniform(0.05, 1.0, (10, 5)) * rng.choice([0.3, 1.0], (10, 1))
        z2 = (1 + (lam - 1) * share) * rng.chisquare(1, (10, 5))
        flagged += int(flag_trials(z2.sum(axis=1), np.full(10, 5), share, z2, TYPED).flagged.sum())
        total += 10
    assert flagged / total <= 0.02


@pytest.mark.parametrize("lam", np.geomspace(GRID[118], GRID[119], 6))
def test_a_narrow_posterior_is_not_snapped_to_the_grid(lam: float) -> None:
    """Issue 54: the posterior's moments were summed on the grid's points (24 a decade,
    10% apart), so a posterior narrower than that (3000 dof, 200 sessions of 5 point
    trials: sigma 2.6%) snapped toward the nearest point: the pooled multiplier moved by up
    to 2% with where its truth fell between two points. With every direction all placing
    and an anchor of no weight the posterior of ``1 / lambda`` is Gamma(n / 2, S / 2): its
    scale is exactly ``S / n`` on ``n`` dof, wherever that lies on the grid."""
    n = 3000
    share, z2 = np.ones((n, 1)), np.full((n, 1), lam)  # S = n lam
    post = posterior(trial_loglik(share, z2).sum(axis=0),
                     PlacingPrior(scale=1.0, dof=1e-9, source="none"))  # fmt: skip
    assert post.scale == pytest.approx(lam, rel=1e-3)
    assert post.dof == pytest.approx(n, rel=1e-2)


def test_an_operators_sessions_supersede_the_typed_resolution() -> None:
    """An operator placing 3x worse than typed (multiplier 9), their other sessions saying
    so on 38 dof: a two-trial method-2 session's multiplier is theirs, not pulled toward the
    typed 1 (on the typed resolution's 2 dof beside them it came out 0.960 of 9 on average
    over these sessions: 2 / 42 of the way to 1). Alone, the typed word still weighs 2 dof."""
    prior = PlacingPrior(scale=9.0, dof=38.0, source="19 other sessions of operator Ada")
    assert NoiseModel().anchor().dof == 2.0
    options = EstimateOptions(noise=NoiseModel(prior=prior))
    lam = [estimate_session(bench.session(Method.GROUND, 54_000 + s, 2, 3.0), options,
                            line_fits=False).factor for s in range(30)]  # fmt: skip
    ratio = np.array([f.placing_variance / 9.0 for f in lam if f is not None])
    assert len(ratio) == 30
    assert 0.98 < ratio.mean() < 1.03
