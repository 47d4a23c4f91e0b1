"""Robust, then pooled: which trials' misclosures stay out of the pool (issue 54).

Before any pooling each trial is tested (Baarda's global test at
:data:`BAARDA_LEVEL`) against the typed model (its misclosure's chi-square) and against
the rest (its chi-square under the posterior predictive of every other unflagged trial,
the anchor and the operator's prior); a trial both reject is **flagged** (the worst
first, then again without it: :func:`flag_trials`), kept out of the posterior
(:mod:`twopose.uncertainty.placing_variance`) and widened by its own misfit. With too
little beside it to say what "the rest" is, the typed test alone decides. A trial another
test flagged (its estimate off the others' or off its truth) lies in no rest (``out``).
The likelihood of the trials kept is truncated (:func:`_kept_chance`): the test keeps the
trials below a cut, and the kept ones alone would understate ``lambda``.

**A typo is tested where a typed pose can move the misclosure.** A mistyped translation
moves only the directions the placing moves (its share ``beta > 0``: the typed
translations' covariance is of full rank, so their effects span exactly what it spans); a
direction of pixels alone (``beta = 0``) carries none of it, and tested beside it dilutes
it. A line's or a ground point's three-pose misclosure has 2 dof, one of them pixels alone:
its typed poses' test is on 1 (a new user's r6 G8: a line's 1 in typo at 29 on 2 dof, p
0.012 against the rest, 0.0025 on its placing direction). So a trial is flagged when the
test of its whole misclosure (any blunder: a detection's too) or the test of its placing
directions (:func:`placing_directions`) rejects, each against the typed model and the
rest; a trial without a pixel-only direction (a point's) has the one test.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from scipy import special

from twopose.arrays import F64, Bools, Ints
from twopose.uncertainty.noise import PlacingPrior
from twopose.uncertainty.placing_variance import (
    GRID,
    LOG_GRID,
    Posteriors,
    grid_weights,
    mass_at,
    posterior,
    trial_information,
    trial_loglik,
)

__all__ = [
    "BAARDA_LEVEL",
    "POOL_LEVEL",
    "Flags",
    "flag_trials",
    "placing_directions",
    "trial_pvalues",
]

#: Baarda's global test of a trial's misclosure: 0.5%. Not 0.1%: there a sixth of the 1 in
#: blunders of the simulator's geometry hide in the misclosure's noise; not 1%: the test
#: of a trial of one target against the others (twopose.uncertainty.blunders) catches
#: most of what a looser level would, and a clean trial's false alarm stays far below 2%
#: (benchmarks/bench_noise.py).
BAARDA_LEVEL = 0.005
#: A trial beside a sharp rest (20 dof: its multiplier known to 30%) is pooled while its test
#: against the rest accepts at 5%; flagged below 0.5%, in between neither (:func:`_kept_chance`).
#: Pooled to 0.5%, an operator's unflagged typos widened the rest, which passed more (r6 G8).
POOL_LEVEL = 0.05
_SHARP_REST = 20.0
#: The rounds of the robust search at most (it settles in two or three).
_ROUNDS = 20
#: Less information than this beside a trial (other trials', the prior's) is none: the
#: typed test alone decides whether it is flagged.
_SOMETHING_BESIDE = 0.5
#: A direction whose placing share is below this is of pixels alone (they come out exactly
#: 0, or 1e-3 and more).
_PIXELS_ALONE = 1e-6


def _rest_of_each(L: F64, info: F64, use: Bools) -> tuple[F64, F64]:
    """Each trial's "rest": every other used trial's log-likelihood and information (T, G)."""
    mine_L, mine_info = np.where(use[:, None], L, 0.0), np.where(use[:, None], info, 0.0)
    return mine_L.sum(axis=0)[None] - mine_L, mine_info.sum(axis=0)[None] - mine_info


def trial_pvalues(
    chi2: F64, dof: Ints, share: F64, z2: F64, rest: Posteriors, beside: F64
) -> tuple[F64, F64]:
    """(T,) each trial's p-value against the typed model, and against ``rest``.

    Against the rest: its statistic (the chi-square of its misclosure at the rest's
    multiplier) under the rest's posterior predictive, the scaled chi-square at every
    multiplier on the grid weighed by the rest's posterior. Not Fisher's F: F lets the
    rest's uncertainty scale every direction, while a direction mostly of pixels barely
    depends on the multiplier, so F made a trial whose poses are 1 in off pass beside two
    trials that knew little (issue 54's F1: a blunder fed the operator's prior). NaN
    where too little lies beside the trial (``beside`` (T,): the information of every
    other trial, flagged or not, and the prior's): nothing to test it against.
    """
    with np.errstate(invalid="ignore", divide="ignore"):
        p_typed = np.where(dof > 0, special.chdtrc(np.maximum(dof, 1), chi2), np.nan)
        d = 1.0 + (rest.scale[:, None] - 1.0) * share
        under = (z2 / np.where(d > 0, d, np.inf)).sum(axis=1)
        k, c = _satterthwaite(np.maximum(dof, 1), share, rest.scale)
        cols = _massive(rest.weights)
        tail = special.chdtrc(k[:, cols], under[:, None] / c[:, cols])
        p_rest = (rest.weights[:, cols] * tail).sum(axis=1)
    enough = (dof > 0) & (beside >= _SOMETHING_BESIDE)
    return p_typed, np.where(enough, p_rest, np.nan)


@dataclass(frozen=True, kw_only=True)
class Flags:
    """Which trials' poses disagree (:func:`flag_trials`), and what the others say.

    ``flagged`` and ``p`` (T,): the p-value against the rest (the typed model's where
    nothing lies beside the trial; NaN: no redundancy), the smaller of its two tests' where
    it has a direction of pixels alone (see the module). ``kept`` (T, G): each trial's
    log-likelihood of the multiplier *given that it was not flagged* (the test keeps the
    trials below a cut, so the kept ones alone would understate ``lambda``: each is
    divided by the chance to fall below its cut at ``lambda``, the truncated likelihood),
    zero for a flagged or untested trial; ``info`` (T, G) their degrees of freedom.
    """

    flagged: Bools
    p: F64
    kept: F64
    info: F64


def flag_trials(
    chi2: F64,
    dof: Ints,
    share: F64,
    z2: F64,
    anchor: PlacingPrior,
    prior: PlacingPrior | None = None,
    *,
    level: float = BAARDA_LEVEL,
    out: Bools | None = None,
) -> Flags:
    """Which trials' poses disagree (Baarda, see the module), and what the others say.

    ``chi2``, ``dof`` (T,), ``share``, ``z2`` (T, M): the trials' misclosures (a trial
    without redundancy is never flagged). A trial is flagged when both its test against
    the typed model and its test against the rest reject at ``level``. "The rest" starts
    as the half of the trials that fit the typed model best (so that many bad trials
    cannot hide each other), then is every trial not flagged, until it stays the same.
    ``out`` (T,): trials another test flagged (their estimate off the others', off their
    truth): their misclosures are no operator's, so they lie in no trial's rest and are
    never flagged here (a typo can shrink its trial's misclosure, and a rest holding it
    flagged a clean trial: the new user's F2).
    """
    T = len(chi2)
    has = (dof > 0) & np.isfinite(chi2)
    tested = has & (True if out is None else ~out)
    L, info = trial_loglik(share, z2), trial_information(share)
    if not tested.any():
        zero = np.zeros_like(L)
        return Flags(flagged=np.zeros(T, dtype=bool), p=np.full(T, np.nan), kept=zero, info=zero)
    # what lies beside each trial at all (flagged trials too): a rest to test against
    at_one = np.where(has, info[:, int(np.argmin(np.abs(LOG_GRID)))], 0.0)
    beside = at_one.sum() - at_one
    if prior is not None and math.isfinite(prior.dof):
        beside = beside + prior.dof
    # the rest starts as a robust guess (the median trial's), so that many bad trials
    # cannot hide each other; then the pool it keeps, until that stays the same
    start = _robust_scale(np.where(tested, dof, 0), share, L)
    first = beside.max() + anchor.dof
    around = PlacingPrior(scale=start, dof=first, source="a guess")
    flat = np.zeros((1, GRID.size))
    guess = (mass_at(np.full(T, start)) if not math.isfinite(first) else
             np.repeat(grid_weights(flat, around, None), T, axis=0))  # fmt: skip
    rest = Posteriors(scale=np.full(T, start), dof=np.full(T, first), information=beside,
                       at_limit=np.zeros(T, dtype=bool), weights=guess)  # fmt: skip
    pool = np.zeros(T, dtype=bool)
    sharp = (beside >= _SHARP_REST) & math.isfinite(anchor.dof)  # an anchor stated exactly
    pool_level = np.where(sharp, max(level, POOL_LEVEL), level)  # is a rest that learns nothing
    typo = placing_directions(dof, share, z2)
    for _ in range(_ROUNDS):
        p_typed, p_rest = trial_pvalues(chi2, dof, share, z2, rest, beside)
        typed_off, no_rest = p_typed < level, np.isnan(p_rest)
        keep = tested & ~(typed_off & (no_rest | (p_rest < level)))
        if typo is not None:  # a typed pose's test, on the directions it can move
            q_typed, q_rest = trial_pvalues(typo[0], typo[1], share, typo[2], rest, beside)
            keep &= ~((q_typed < level) & (np.isnan(q_rest) | (q_rest < level)))
            q = np.where(np.isfinite(q_rest), q_rest, q_typed)
        pooled = keep & ~(typed_off & (no_rest | (p_rest < pool_level)))
        chance = _kept_chance(dof, share, rest, p_rest, level, pool_level)
        kept = np.where(pooled[:, None], L - chance, 0.0)
        if np.array_equal(pooled, pool):
            break
        pool = pooled
        rest_L, rest_info = _rest_of_each(kept, info, pooled)
        rest = posterior(rest_L, anchor, prior, rest_info)  # type: ignore[assignment]
    flagged, clean = tested & ~keep, pooled
    p = np.where(np.isfinite(p_rest), p_rest, p_typed)
    if typo is not None:  # the smaller of the two tests'
        p = np.where(np.isfinite(q), np.fmin(p, q), p)
    return Flags(
        flagged=flagged,
        p=np.where(has, p, np.nan),
        kept=kept,
        info=np.where(clean[:, None], info, 0.0),
    )


def placing_directions(dof: Ints, share: F64, z2: F64) -> tuple[F64, Ints, F64] | None:
    """The trials' misclosures on the directions a typed pose can move (see the module).

    ``chi2`` (T,), ``dof`` (T,) and ``z2`` (T, M) with the directions of pixels alone
    (``share`` below :data:`_PIXELS_ALONE`) left out; None where no trial has one (the
    whole misclosure's test is the typed poses' too). A trial with no placing direction
    has 0 dof: untested here.
    """
    real = dof > 0
    moved = share >= _PIXELS_ALONE
    n = np.where(real, moved.sum(axis=1), 0)
    if not (real & (n < dof)).any():
        return None
    z2_m = np.where(moved & real[:, None], np.nan_to_num(z2), 0.0)
    return z2_m.sum(axis=1), n, z2_m


def _robust_scale(dof: Ints, share: F64, L: F64) -> float:
    """A first guess of the multiplier that a few bad trials cannot move.

    The median, over the trials, of each one's own maximum over the median of that maximum
    when the multiplier is 1 (about a chi-square on its placing directions over their count).
    """
    tested = dof > 0
    own = GRID[np.argmax(L[tested], axis=1)]
    placing = np.maximum(np.rint(share[tested].sum(axis=1)), 1)
    median = special.chdtri(placing, 0.5) / placing
    return float(np.clip(np.median(own / median), GRID[0], GRID[-1]))


def _kept_chance(dof: Ints, share: F64, rest: Posteriors, p: F64, level: float, at: F64) -> F64:
    """(T, G) the log-chance, at every multiplier, that a trial is pooled.

    A trial is pooled when either test accepts it: its chi-square under the typed model
    below that test's cut (``level``), or its statistic at the rest's multiplier below the
    cut of the rest's predictive (``at``, where ``p`` says there is a rest); the chance is
    the larger of the two (the two statistics nearly proportional). Each statistic,
    ``sum_k w_k chi2_1`` with ``w_k`` the ratio of the direction's variance at ``lambda``
    to the one it is tested at, is Satterthwaite's scaled chi-square.
    """
    d = np.maximum(dof, 1)
    k, c = _satterthwaite(d, share, np.ones(len(d)))
    typed = special.chdtr(k, special.chdtri(d, level)[:, None] / c)
    k, c = _satterthwaite(d, share, rest.scale)
    has_rest = np.isfinite(p)
    cut = _predictive_cut(k, c, rest.weights, at, has_rest)
    with np.errstate(invalid="ignore", divide="ignore"):
        against_rest = special.chdtr(k, cut[:, None] / c)
    chance = np.where(has_rest[:, None], np.fmax(typed, against_rest), typed)
    return np.asarray(np.log(np.clip(chance, 1e-300, 1.0)))


def _satterthwaite(dof: Ints, share: F64, tested_at: F64) -> tuple[F64, F64]:
    """(T, G) ``k`` and ``c``: a trial's statistic is about ``c chi2_k`` at every multiplier.

    Tested at the multiplier ``tested_at`` (T,), by Satterthwaite's scaled chi-square. Its
    ``dof`` directions: those with a placing share weigh their variance at ``lambda``
    over the one tested at, the others (pixels alone) 1.
    """
    beta = share[..., None]  # (T, M, 1)
    at = 1.0 + (np.asarray(tested_at)[:, None, None] - 1.0) * beta
    w = np.where(beta > 0, (1.0 + (GRID - 1.0) * beta) / at, 0.0)
    rest = (dof - (share > 0).sum(axis=1))[:, None]  # the pixel-only directions
    s1, s2 = w.sum(axis=1) + rest, (w**2).sum(axis=1) + rest
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.asarray(s1**2 / s2), np.asarray(s2 / s1)


def _massive(weights: F64) -> Ints:
    """The grid's columns where any row of ``weights`` (R, G) has more than 1e-8 of its mass.

    Each row sums to 1: what a predictive's sum needs, to 2.4e-6 of it at most (a
    posterior spans a few decades of the grid's ten).
    """
    return np.flatnonzero((weights > 1e-8).any(axis=0))


def _predictive_cut(k: F64, c: F64, weights: F64, level: F64, where: Bools) -> F64:
    """(T,) the statistic whose predictive tail (``weights`` over ``c chi2_k``) is ``level``.

    Bisection in the log of the statistic, on the rows ``where`` (NaN elsewhere), between
    the smallest and the largest of the grid's own ``level`` quantiles (the mixture's
    lies between them): 30 halvings leave 1e-9 of their ratio's log.
    """
    out = np.full(k.shape[0], np.nan)
    rows = np.flatnonzero(where)
    if rows.size:
        cols = _massive(weights[rows])
        k_, c_, w_ = k[np.ix_(rows, cols)], c[np.ix_(rows, cols)], weights[np.ix_(rows, cols)]
        at = np.broadcast_to(level, where.shape)[rows]
        with np.errstate(invalid="ignore", divide="ignore"):
            q = np.log(c_ * special.chdtri(k_, at[:, None]))
        heavy = w_ > 1e-8
        a = np.where(heavy, q, np.inf).min(axis=1)
        b = np.where(heavy, q, -np.inf).max(axis=1)
        for _ in range(30):
            mid = 0.5 * (a + b)
            with np.errstate(invalid="ignore", divide="ignore"):
                tail = (w_ * special.chdtrc(k_, np.exp(mid)[:, None] / c_)).sum(axis=1)
            a, b = np.where(tail > at, mid, a), np.where(tail > at, b, mid)
        out[rows] = np.exp(0.5 * (a + b))
    return out
