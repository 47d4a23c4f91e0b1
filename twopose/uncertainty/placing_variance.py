"""The placing variance's multiplier ``lambda``, always estimated, robustly (issue 54).

Each trial's misclosure (:mod:`twopose.uncertainty.misclosure`) has the covariance ``A + lambda B``:
``B`` what the placing sigma the regions start from (typed, or a board's) gives, ``A``
the rest. In its basis the trial's log-likelihood of ``lambda`` is a sum of scalars,
``-1/2 sum [log(1 + (lambda - 1) beta) + z^2 / (1 + (lambda - 1) beta)]``, computed here
on one log-spaced grid (:data:`GRID`, 1e-4 to 1e6, 24 points a decade; no cap is hit
silently: a posterior with mass at either end says so, :attr:`Posterior.at_limit`).

**No pretest.** ``lambda`` is never taken as exactly 1 because a test did not reject:
its posterior is always used, with its uncertainty (:func:`posterior`). The prior is a
scaled inverse chi-square, ``lambda0`` on ``nu0`` degrees of freedom
(:class:`twopose.uncertainty.noise.PlacingPrior`): an **anchor** (the typed resolution on
:data:`TYPED_PRIOR_DOF` degrees of freedom, or a board session's measured ``[placing]`` on
its own) times, when there is one, the **operator's** (the same operator's other sessions
of the run, :func:`operator_priors`; the recorder's per-operator noise file). The
posterior, on the grid (integrated between its points), is summarised as a scaled inverse
chi-square by its precision's two moments (``1 / lambda``: mean ``1 / s^2``, variance
``2 / (nu s^4)``; exact when the data are all placing); every region is propagated with
the placing sigma times ``s`` and its quantile is Fisher's F on ``nu``
(:meth:`twopose.uncertainty.noise.VarianceFactor.widening`). The
**minimum-dof guard**: with less than :data:`twopose.uncertainty.noise.MIN_PLACING_DOF` degrees of
freedom of information beyond the anchor, nothing is estimated and the regions assume the
anchor's sigma unwidened, said as "not enough data".

**Robust, then pooled.** Before any pooling each trial is tested (Baarda's global test at
:data:`BAARDA_LEVEL`) against the typed model (its misclosure's chi-square) and against
the rest (its chi-square under the posterior predictive of every other unflagged trial,
the anchor and the operator's prior); a trial both reject is **flagged** (the worst
first, then again without it: :func:`flag_trials`), kept out of the posterior and widened
by its own misfit. With too little beside it to say what "the rest" is, the typed test
alone decides. A trial another test flagged (its estimate off the others' or off its truth)
lies in no rest (``out``).

(Near 600 lines: the likelihood on the grid, its posterior, the robust test whose
truncation that likelihood corrects, and the operator's pooling of the same curves are one
computation on one grid; split, each part would import the others' privates.)
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from scipy import special

from twopose.arrays import F64, Bools, Ints
from twopose.uncertainty.anchor_conflict import as_guess, group_anchor
from twopose.uncertainty.hand import pooled_trials
from twopose.uncertainty.noise import MIN_PLACING_DOF, PlacingPrior

__all__ = [
    "BAARDA_LEVEL",
    "GRID",
    "POOL_LEVEL",
    "Flags",
    "Posterior",
    "SessionNoise",
    "flag_trials",
    "operator_priors",
    "posterior",
    "trial_loglik",
]

#: The multipliers searched: a placing sigma 1/100 to 1000 times the one assumed.
GRID = np.geomspace(1e-4, 1e6, 241)
_LOG_GRID = np.log(GRID)
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
#: The posterior's moments are summed on this many points a grid step (:func:`_precision_moments`).
_REFINE = 8
#: The rounds of the robust search at most (it settles in two or three).
_ROUNDS = 20
#: Less information than this beside a trial (other trials', the prior's) is none: the
#: typed test alone decides whether it is flagged.
_SOMETHING_BESIDE = 0.5
#: A posterior with more than this mass at the grid's first or last points is at its limit.
_AT_LIMIT = 1e-3
#: Between-session spread (type II maximum likelihood of the prior's dof over these).
_SPREAD_DOF = np.array([1, 2, 3, 4, 6, 8, 12, 16, 24, 32, 48, 64, 96, 128, 192, 256, 384,
                        512, 768, 1024, np.inf])  # fmt: skip


def trial_loglik(share: F64, z2: F64) -> F64:
    """(T, G) each trial's log-likelihood of every multiplier on :data:`GRID`.

    ``share``, ``z2`` (T, M): its directions' placing share and squared component; a
    direction without placing (``beta = 0``) does not depend on ``lambda`` and is left out.
    """
    beta = np.asarray(share, dtype=np.float64)[..., None]
    d = 1.0 + (GRID - 1.0) * beta  # (T, M, G)
    d = np.where(d > 0, d, np.finfo(float).tiny)
    terms = np.log(d) + np.asarray(z2, dtype=np.float64)[..., None] / d
    return np.asarray(-0.5 * np.where(beta > 0, terms, 0.0).sum(axis=-2))


def fisher_dof(share: F64, lam: float | F64) -> F64:
    """The degrees of freedom a multiplier ``lam`` rests on.

    ``sum (lam beta / (1 + (lam - 1) beta))^2`` over the directions (the last axis), so
    that ``Var(lambda) = 2 lambda^2 / f``.
    """
    beta = np.asarray(share, dtype=np.float64)
    lam_ = np.asarray(lam, dtype=np.float64)[..., None]
    return np.asarray(((lam_ * beta / (1.0 + (lam_ - 1.0) * beta)) ** 2).sum(axis=-1))


def trial_information(share: F64) -> F64:
    """(T, G) each trial's :func:`fisher_dof` at every multiplier on :data:`GRID`."""
    beta = np.asarray(share, dtype=np.float64)[..., None]
    return np.asarray(((GRID * beta / (1.0 + (GRID - 1.0) * beta)) ** 2).sum(axis=-2))


def _inv_chi2(scale: float, dof: float, *, density: bool = True) -> F64:
    """(G,) the scaled inverse chi-square's log-density on the grid (up to a constant).

    Without ``density``: the likelihood of ``dof`` degrees of freedom of data whose
    variance estimate is ``scale`` (the exponent ``dof / 2``, not ``dof / 2 + 1``), as the
    operator's other sessions are: multiplied by the anchor's density, the posterior's
    degrees of freedom are the sum of the two.
    """
    if not (math.isfinite(dof) and dof > 0 and scale > 0):
        return np.zeros_like(GRID)
    power = 0.5 * dof + (1.0 if density else 0.0)
    return np.asarray(-power * _LOG_GRID - 0.5 * dof * scale / GRID)


@dataclass(frozen=True, kw_only=True)
class Posterior:
    """The multiplier's posterior, as a scaled inverse chi-square (``scale`` on ``dof``).

    ``information``: its degrees of freedom beyond the anchor (the data's and the
    operator's); ``at_limit``: mass at the grid's end (the multiplier is beyond it).
    """

    scale: float
    dof: float
    information: float
    at_limit: bool = False


def posterior(
    loglik: F64, anchor: PlacingPrior, prior: PlacingPrior | None = None, info: F64 | None = None
) -> Posterior:
    """The multiplier's posterior from the data's log-likelihood (G,) or (R, G) (rows).

    ``anchor`` (the typed or the board's sigma) and ``prior`` (the operator's) multiply it;
    ``info`` (G,) or (R, G): the data's degrees of freedom along the grid
    (:func:`trial_information`, summed), read at the posterior's scale (else none). An
    anchor stated exactly (infinite dof) is the posterior: nothing to estimate.
    """
    L = np.atleast_2d(np.asarray(loglik, dtype=np.float64))
    R = L.shape[0]
    if not math.isfinite(anchor.dof):  # stated exactly: nothing to estimate
        if np.ndim(loglik) == 1:
            return Posterior(scale=1.0, dof=math.inf, information=0.0)
        return _Posteriors(scale=np.ones(R), dof=np.full(R, math.inf),  # type: ignore[return-value]
                           information=np.zeros(R), at_limit=np.zeros(R, dtype=bool),
                           weights=_at(np.ones(R)))  # fmt: skip
    p = _grid_weights(L, anchor, prior)
    mean, var = _precision_moments(_log_mass(L, anchor, prior), p)
    scale, dof = 1.0 / mean, 2.0 * mean**2 / var
    at_limit = (p[:, :2].sum(axis=1) > _AT_LIMIT) | (p[:, -2:].sum(axis=1) > _AT_LIMIT)
    if info is None:
        info = np.zeros(R)
    else:
        curves = np.broadcast_to(np.atleast_2d(np.asarray(info, dtype=np.float64)), L.shape)
        at = np.log(scale)
        info = np.array([np.interp(a, _LOG_GRID, c) for a, c in zip(at, curves, strict=True)])
    if prior is not None and math.isfinite(prior.dof):
        info = info + prior.dof
    if R == 1 and np.ndim(loglik) == 1:
        return Posterior(scale=float(scale[0]), dof=float(dof[0]), information=float(info[0]),
                         at_limit=bool(at_limit[0]))  # fmt: skip
    return _Posteriors(scale=scale, dof=dof, information=info, at_limit=at_limit, weights=p)  # type: ignore[return-value]


def _log_mass(L: F64, anchor: PlacingPrior, prior: PlacingPrior | None) -> F64:
    """(R, G) the posterior's log-density in ``log(lambda)`` (up to a constant) on the grid."""
    logp = L + _inv_chi2(anchor.scale, anchor.dof)
    if prior is not None:  # the operator's other sessions: data, not a second prior
        logp = logp + _inv_chi2(prior.scale, prior.dof, density=False)
    # on a log grid: d lambda = lambda d log(lambda)
    return np.asarray(logp + _LOG_GRID)


def _grid_weights(L: F64, anchor: PlacingPrior, prior: PlacingPrior | None) -> F64:
    """(R, G) the posterior's mass at each grid point, for each row of ``L`` (R, G)."""
    logw = _log_mass(L, anchor, prior)
    p = np.exp(logw - logw.max(axis=1, keepdims=True))
    return np.asarray(p / p.sum(axis=1, keepdims=True))


def _precision_moments(logw: F64, p: F64) -> tuple[F64, F64]:
    """(R,) the mean and variance of ``1 / lambda`` under each row's posterior.

    Integrated between the grid's points: ``logw`` (R, G), the log-density in
    ``log(lambda)``, is smooth, so a cubic spline of it through the columns where ``p``
    (R, G, its mass on the grid) has any is exact to far below the moments' own error, and
    its exponential is summed on :data:`_REFINE` points a grid step. On the grid's points
    alone the moments snapped toward the nearest point: a posterior of a few thousand
    degrees of freedom (sigma 2.6% at 3000) is narrower than the grid's step (10%), and the
    pooled multiplier of 200 sessions of 5 trials moved by up to 2% with where its truth
    fell between two points (benchmarks/bench_noise.py).
    """
    from scipy import interpolate  # here: a re-run that reuses its analysis never loads it

    heavy = np.flatnonzero((p > 1e-12).any(axis=0))
    lo, hi = max(int(heavy[0]) - 2, 0), min(int(heavy[-1]) + 2, GRID.size - 1)
    u = _LOG_GRID[lo : hi + 1]
    fine = np.linspace(u[0], u[-1], _REFINE * (hi - lo) + 1)
    spline = interpolate.CubicSpline(u, logw[:, lo : hi + 1], axis=1)(fine)
    w = np.exp(spline - spline.max(axis=1, keepdims=True))
    w /= w.sum(axis=1, keepdims=True)
    tau = np.exp(-fine)
    mean = w @ tau
    var = np.clip(w @ tau**2 - mean**2, 1e-300, None)
    return mean, var


def _at(scale: F64) -> F64:
    """(R, G) all the mass at the grid point nearest each ``scale`` (R,): a multiplier known."""
    w = np.zeros((len(scale), GRID.size))
    w[np.arange(len(scale)), np.abs(_LOG_GRID - np.log(scale)[:, None]).argmin(axis=1)] = 1.0
    return w


@dataclass(frozen=True, kw_only=True)
class _Posteriors:
    """Rows of posteriors (:func:`posterior` of (R, G) log-likelihoods).

    ``weights`` (R, G): each one's mass on :data:`GRID` (what the test of a trial against
    it integrates over).
    """

    scale: F64
    dof: F64
    information: F64
    at_limit: Bools
    weights: F64


def _rest_of_each(L: F64, info: F64, use: Bools) -> tuple[F64, F64]:
    """Each trial's "rest": every other used trial's log-likelihood and information (T, G)."""
    mine_L, mine_info = np.where(use[:, None], L, 0.0), np.where(use[:, None], info, 0.0)
    return mine_L.sum(axis=0)[None] - mine_L, mine_info.sum(axis=0)[None] - mine_info


def trial_pvalues(
    chi2: F64, dof: Ints, share: F64, z2: F64, rest: _Posteriors, beside: F64
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
    nothing lies beside the trial; NaN: no redundancy). ``kept`` (T, G): each trial's
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
    at_one = np.where(has, info[:, int(np.argmin(np.abs(_LOG_GRID)))], 0.0)
    beside = at_one.sum() - at_one
    if prior is not None and math.isfinite(prior.dof):
        beside = beside + prior.dof
    # the rest starts as a robust guess (the median trial's), so that many bad trials
    # cannot hide each other; then the pool it keeps, until that stays the same
    start = _robust_scale(np.where(tested, dof, 0), share, L)
    first = beside.max() + anchor.dof
    around = PlacingPrior(scale=start, dof=first, source="a guess")
    flat = np.zeros((1, GRID.size))
    guess = (_at(np.full(T, start)) if not math.isfinite(first) else
             np.repeat(_grid_weights(flat, around, None), T, axis=0))  # fmt: skip
    rest = _Posteriors(scale=np.full(T, start), dof=np.full(T, first), information=beside,
                       at_limit=np.zeros(T, dtype=bool), weights=guess)  # fmt: skip
    pool = np.zeros(T, dtype=bool)
    sharp = (beside >= _SHARP_REST) & math.isfinite(anchor.dof)  # an anchor stated exactly
    pool_level = np.where(sharp, max(level, POOL_LEVEL), level)  # is a rest that learns nothing
    for _ in range(_ROUNDS):
        p_typed, p_rest = trial_pvalues(chi2, dof, share, z2, rest, beside)
        typed_off, no_rest = p_typed < level, np.isnan(p_rest)
        keep = tested & ~(typed_off & (no_rest | (p_rest < level)))
        pooled = tested & ~(typed_off & (no_rest | (p_rest < pool_level)))
        chance = _kept_chance(dof, share, rest, p_rest, level, pool_level)
        kept = np.where(pooled[:, None], L - chance, 0.0)
        if np.array_equal(pooled, pool):
            break
        pool = pooled
        rest_L, rest_info = _rest_of_each(kept, info, pooled)
        rest = posterior(rest_L, anchor, prior, rest_info)  # type: ignore[assignment]
    flagged, clean = tested & ~keep, pooled
    p = np.where(np.isfinite(p_rest), p_rest, p_typed)
    return Flags(
        flagged=flagged,
        p=np.where(has, p, np.nan),
        kept=kept,
        info=np.where(clean[:, None], info, 0.0),
    )


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


def _kept_chance(dof: Ints, share: F64, rest: _Posteriors, p: F64, level: float, at: F64) -> F64:
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


@dataclass(frozen=True, kw_only=True)
class SessionNoise:
    """What one session's misclosures say of its operator's placing.

    A run's first pass, or the recorder's noise file: per redundant trial its chi-square,
    dof and components.
    """

    #: Whose sessions pool: the operator and the method (``""``: no operator named, alone).
    group: str
    chi2: F64  # (T,)
    dof: Ints  # (T,)
    share: F64  # (T, M)
    z2: F64  # (T, M)
    #: The session's id (``""``: not known), named in the priors that pool it.
    name: str = ""
    #: Its base, the placing sigma its multiplier is relative to, in inches (NaN: not
    #: known): sessions of other bases pool as placing variances (:mod:`~twopose.uncertainty.hand`).
    placing_in: float = math.nan


def operator_priors(
    sessions: Sequence[SessionNoise], anchor: PlacingPrior, *, who: str = "operator"
) -> list[PlacingPrior | None]:
    """Each session's prior from the other sessions of its group (None: none to pool).

    Robust first: every trial of the group is tested against all the others
    (:func:`flag_trials`) and a flagged one is left out. Then per session the others'
    pooled likelihood's maximum ``lambda0`` on its degrees of freedom ``F``, shrunk for
    the spread between the group's sessions: the prior's dof is ``min(d0, F)``, ``d0`` the
    type II maximum-likelihood dof of a scaled inverse chi-square at ``lambda0`` that the
    group's sessions' multipliers are drawn from (infinite: they share one). Sessions of
    other bases (typed resolutions) pool as placing variances, each one's prior a multiplier
    of its own base (:func:`twopose.uncertainty.hand.on_one_base`).
    """
    out: list[PlacingPrior | None] = [None] * len(sessions)
    groups: dict[str, list[int]] = {}
    for i, s in enumerate(sessions):
        if s.group:
            groups.setdefault(s.group, []).append(i)
    from twopose.uncertainty.hand import on_one_base, prior_on_own_base

    for group, members in groups.items():
        if len(members) < 2:
            continue
        mine, back, converted = on_one_base([sessions[i] for i in members])
        used, p = _group_anchor(mine, anchor)  # the board tested once, over all of them
        priors = [
            None if prior is None else dataclasses.replace(prior, anchor_p=p)
            for prior in _group_priors(mine, used, group, who)
        ]
        for i, prior, factor in zip(members, priors, back, strict=True):
            out[i] = prior_on_own_base(prior, factor) if converted else prior
    return out


def _group_anchor(sessions: list[SessionNoise], anchor: PlacingPrior) -> tuple[PlacingPrior, float]:
    """:func:`~twopose.uncertainty.anchor_conflict.group_anchor` over ``sessions``' trials."""
    if not anchor.measured or not any(s.share.size for s in sessions):
        return anchor, math.nan
    _, chi2, dof, share, z2 = pooled_trials(sessions)
    return group_anchor(
        chi2, dof, flag_trials(chi2, dof, share, z2, as_guess(anchor)).flagged, anchor
    )


def _group_priors(
    sessions: list[SessionNoise], anchor: PlacingPrior, group: str, who: str
) -> list[PlacingPrior | None]:
    if not any(s.share.size for s in sessions):
        return [None] * len(sessions)
    owner, chi2, dof, share, z2 = pooled_trials(sessions)
    flags = flag_trials(chi2, dof, share, z2, anchor)
    use = (dof > 0) & np.isfinite(chi2) & ~flags.flagged
    L, clean = flags.kept, use.astype(float)
    # the spread from the pooled trials' untruncated likelihoods (a truncated one is flat up)
    raw = np.where(use[:, None] & (L != 0).any(axis=1)[:, None], trial_loglik(share, z2), 0.0)
    per_session = np.stack([raw[owner == k].sum(axis=0) for k in range(len(sessions))])
    spread = _spread_dof(per_session, raw.sum(axis=0))
    out: list[PlacingPrior | None] = []
    for k in range(len(sessions)):
        others = use & (owner != k)
        if not others.any():
            out.append(None)
            continue
        curve = L[others].sum(axis=0)
        lam0 = _maximum(curve)
        info = (clean[others, None] * flags.info[others]).sum(axis=0)
        g = int(np.clip(np.argmax(curve), 1, len(GRID) - 2))  # the curve's own dof: 2x its bend
        bend = (curve[g - 1] - 2 * curve[g] + curve[g + 1]) / (_LOG_GRID[1] - _LOG_GRID[0]) ** 2
        own = max(-2.0 * float(bend), 0.0) if math.isfinite(anchor.dof) else math.inf  # cut at 5%
        f = min(float(np.interp(math.log(lam0), _LOG_GRID, info)), own)  # it tells less
        if round(f) < MIN_PLACING_DOF:
            out.append(None)
            continue
        pooled = {int(o) for o in owner[others]}
        n, names = len(pooled), tuple(sorted({sessions[o].name for o in pooled} - {""}))
        out.append(
            PlacingPrior(scale=lam0, dof=min(f, spread), source=f"{n} other session"
                         f"{'s' if n > 1 else ''} of {who} {group}", sessions=n, pooled=names)
        )  # fmt: skip
    return out


def _maximum(curve: F64) -> float:
    """The log-likelihood ``curve``'s maximum on the grid, refined by a parabola in log."""
    g = int(np.argmax(curve))
    if 0 < g < len(GRID) - 1:
        a, b, c = curve[g - 1], curve[g], curve[g + 1]
        denom = a - 2 * b + c
        shift = 0.5 * (a - c) / denom if denom < 0 else 0.0
        return float(np.exp(_LOG_GRID[g] + shift * (_LOG_GRID[1] - _LOG_GRID[0])))
    return float(GRID[g])


def _spread_dof(per_session: F64, pooled: F64) -> float:
    """The dof ``d0`` that best explains the sessions' multipliers' spread.

    By type II maximum likelihood over :data:`_SPREAD_DOF` (infinite: they share one
    multiplier) jointly with the spread's scale about the pooled maximum: each session's
    likelihood integrated over a scaled inverse chi-square of the sessions' multipliers.
    """
    lam0 = _maximum(pooled)
    best, best_dof = -math.inf, math.inf
    top = per_session.max(axis=1, keepdims=True)
    like = np.exp(per_session - top)  # (S, G), each session's own scale
    for scale in lam0 * np.exp(np.linspace(-0.7, 0.7, 15)):
        for d0 in _SPREAD_DOF:
            if math.isfinite(d0):
                prior = _inv_chi2(scale, float(d0)) + _LOG_GRID
                prior = np.exp(prior - prior.max())
                prior /= prior.sum()
                marginal = float(np.log(np.clip(like @ prior, 1e-300, None)).sum())
            else:  # one shared multiplier: each session's likelihood at it
                logs = np.log(np.clip(like, 1e-300, None))
                marginal = float(sum(np.interp(math.log(scale), _LOG_GRID, r) for r in logs))
            if marginal > best + 1e-9:
                best, best_dof = marginal, float(d0)
    return best_dof
