"""An operator's hand pooled across sessions typed at different resolutions (issue 54; a
new user's r5 F1): the prior is the operator's placing variance, not a multiplier of
whatever each session typed. Ada places 0.16 in; typed 0.16 in on four days and 0.04 in on
two, the multipliers pooled as one gave the 0.04 in days the 1x of the others and every
clean trial of them was flagged as a typo."""

from __future__ import annotations

import math

import numpy as np
import pytest

from twopose.uncertainty.hand import rebased
from twopose.uncertainty.noise import PlacingPrior
from twopose.uncertainty.operator_pool import SessionNoise, operator_priors
from twopose.uncertainty.placing_variance import GRID, trial_loglik
from twopose.uncertainty.robust_flags import flag_trials

TYPED = PlacingPrior(scale=1.0, dof=2.0, source="the typed resolution")
HAND_IN = 0.16


def _session(typed_in: float, rng: np.random.Generator, beta: float = 0.8) -> SessionNoise:
    """Four trials of a 0.16 in hand typed ``typed_in`` (4 directions, ``beta`` placing)."""
    lam = (HAND_IN / typed_in) ** 2
    share = np.full((4, 4), beta)
    z2 = (1 + (lam - 1) * share) * rng.standard_normal((4, 4)) ** 2
    return SessionNoise(group="Ada (point)", chi2=z2.sum(axis=1), dof=np.full(4, 4),
                        share=share, z2=z2, placing_in=typed_in)  # fmt: skip


def test_rebasing_keeps_the_likelihood_of_the_placing_variance() -> None:
    rng = np.random.default_rng(0)
    s = _session(0.04, rng, beta=0.6)
    r = rebased(s, 0.16)  # lambda' = lambda (0.04 / 0.16)^2
    own = trial_loglik(s.share, s.z2).sum(axis=0)
    moved = trial_loglik(r.share, r.z2).sum(axis=0)
    at = np.interp(np.log(GRID * 16.0), np.log(GRID), own)  # own at lambda = 16 lambda'
    inside = (GRID > 1e-2) & (GRID < 1e3)
    diff = (moved - at)[inside]
    assert np.ptp(diff) < 0.05  # equal up to a constant (the interpolation's error)
    assert r.chi2 is s.chi2  # its own typed model's test is kept


def test_one_hand_typed_at_two_resolutions_gives_each_session_its_own_multiplier() -> None:
    rng = np.random.default_rng(3)
    sessions = [_session(0.16, rng) for _ in range(4)] + [_session(0.04, rng) for _ in range(2)]
    priors = operator_priors(sessions, TYPED)
    assert all(p is not None for p in priors)
    scales = [p.scale for p in priors if p is not None]
    for scale in scales[:4]:  # typed right: about 1
        assert 0.6 < scale < 1.6
    for scale in scales[4:]:  # typed 4x too fine: about 16, never the others' 1x
        assert 10 < scale < 26
    assert "across their typed resolutions" in priors[4].source  # type: ignore[union-attr]
    # the fine days' clean trials are not flagged against that prior
    for s, prior in zip(sessions[4:], priors[4:], strict=True):
        flags = flag_trials(s.chi2, s.dof, s.share, s.z2, TYPED, prior)
        assert not flags.flagged.any()


def test_a_session_of_unknown_base_beside_known_ones_is_left_out() -> None:
    rng = np.random.default_rng(4)
    known = [_session(0.16, rng) for _ in range(3)]
    old = [_session(0.04, rng) for _ in range(3)]
    old = [SessionNoise(group=s.group, chi2=s.chi2, dof=s.dof, share=s.share, z2=s.z2)
           for s in old]  # fmt: skip
    priors = operator_priors(known + old, TYPED)
    assert all(p is None for p in priors[3:])  # never given a prior it cannot convert
    alone = operator_priors(known, TYPED)
    for with_old, without in zip(priors[:3], alone, strict=True):
        assert with_old is not None
        assert without is not None
        assert with_old.scale == pytest.approx(without.scale, rel=1e-6)  # nothing pooled
        assert math.isclose(with_old.dof, without.dof, rel_tol=1e-6)
