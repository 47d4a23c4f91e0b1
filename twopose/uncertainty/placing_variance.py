"""The placing variance's multiplier ``lambda``, always estimated (issue 54).

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
of the run, :func:`twopose.uncertainty.operator_pool.operator_priors`; the recorder's
per-operator noise file). The
posterior, on the grid (integrated between its points), is summarised as a scaled inverse
chi-square by its precision's two moments (``1 / lambda``: mean ``1 / s^2``, variance
``2 / (nu s^4)``; exact when the data are all placing); every region is propagated with
the placing sigma times ``s`` and its quantile is Fisher's F on ``nu``
(:meth:`twopose.uncertainty.noise.VarianceFactor.widening`). The
**minimum-dof guard**: with less than :data:`twopose.uncertainty.noise.MIN_PLACING_DOF` degrees of
freedom of information beyond the anchor, nothing is estimated and the regions assume the
anchor's sigma unwidened, said as "not enough data".

Which trials enter the likelihood is the robust stage's
(:mod:`twopose.uncertainty.robust_flags`); the operator's pooling of the same curves,
:mod:`twopose.uncertainty.operator_pool`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64, Bools
from twopose.uncertainty.noise import PlacingPrior

__all__ = [
    "GRID",
    "LOG_GRID",
    "Posterior",
    "Posteriors",
    "fisher_dof",
    "grid_weights",
    "inv_chi2",
    "mass_at",
    "posterior",
    "trial_information",
    "trial_loglik",
]

#: The multipliers searched: a placing sigma 1/100 to 1000 times the one assumed.
GRID = np.geomspace(1e-4, 1e6, 241)
LOG_GRID = np.log(GRID)
#: The posterior's moments are summed on this many points a grid step (:func:`_precision_moments`).
_REFINE = 8
#: A posterior with more than this mass at the grid's first or last points is at its limit.
_AT_LIMIT = 1e-3


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


def inv_chi2(scale: float, dof: float, *, density: bool = True) -> F64:
    """(G,) the scaled inverse chi-square's log-density on the grid (up to a constant).

    Without ``density``: the likelihood of ``dof`` degrees of freedom of data whose
    variance estimate is ``scale`` (the exponent ``dof / 2``, not ``dof / 2 + 1``), as the
    operator's other sessions are: multiplied by the anchor's density, the posterior's
    degrees of freedom are the sum of the two.
    """
    if not (math.isfinite(dof) and dof > 0 and scale > 0):
        return np.zeros_like(GRID)
    power = 0.5 * dof + (1.0 if density else 0.0)
    return np.asarray(-power * LOG_GRID - 0.5 * dof * scale / GRID)


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
        return Posteriors(scale=np.ones(R), dof=np.full(R, math.inf),  # type: ignore[return-value]
                           information=np.zeros(R), at_limit=np.zeros(R, dtype=bool),
                           weights=mass_at(np.ones(R)))  # fmt: skip
    p = grid_weights(L, anchor, prior)
    mean, var = _precision_moments(_log_mass(L, anchor, prior), p)
    scale, dof = 1.0 / mean, 2.0 * mean**2 / var
    at_limit = (p[:, :2].sum(axis=1) > _AT_LIMIT) | (p[:, -2:].sum(axis=1) > _AT_LIMIT)
    if info is None:
        info = np.zeros(R)
    else:
        curves = np.broadcast_to(np.atleast_2d(np.asarray(info, dtype=np.float64)), L.shape)
        at = np.log(scale)
        info = np.array([np.interp(a, LOG_GRID, c) for a, c in zip(at, curves, strict=True)])
    if prior is not None and math.isfinite(prior.dof):
        info = info + prior.dof
    if R == 1 and np.ndim(loglik) == 1:
        return Posterior(scale=float(scale[0]), dof=float(dof[0]), information=float(info[0]),
                         at_limit=bool(at_limit[0]))  # fmt: skip
    return Posteriors(scale=scale, dof=dof, information=info, at_limit=at_limit, weights=p)  # type: ignore[return-value]


def _log_mass(L: F64, anchor: PlacingPrior, prior: PlacingPrior | None) -> F64:
    """(R, G) the posterior's log-density in ``log(lambda)`` (up to a constant) on the grid."""
    logp = L + inv_chi2(anchor.scale, anchor.dof)
    if prior is not None:  # the operator's other sessions: data, not a second prior
        logp = logp + inv_chi2(prior.scale, prior.dof, density=False)
    # on a log grid: d lambda = lambda d log(lambda)
    return np.asarray(logp + LOG_GRID)


def grid_weights(L: F64, anchor: PlacingPrior, prior: PlacingPrior | None) -> F64:
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
    u = LOG_GRID[lo : hi + 1]
    fine = np.linspace(u[0], u[-1], _REFINE * (hi - lo) + 1)
    spline = interpolate.CubicSpline(u, logw[:, lo : hi + 1], axis=1)(fine)
    w = np.exp(spline - spline.max(axis=1, keepdims=True))
    w /= w.sum(axis=1, keepdims=True)
    tau = np.exp(-fine)
    mean = w @ tau
    var = np.clip(w @ tau**2 - mean**2, 1e-300, None)
    return mean, var


def mass_at(scale: F64) -> F64:
    """(R, G) all the mass at the grid point nearest each ``scale`` (R,): a multiplier known."""
    w = np.zeros((len(scale), GRID.size))
    w[np.arange(len(scale)), np.abs(LOG_GRID - np.log(scale)[:, None]).argmin(axis=1)] = 1.0
    return w


@dataclass(frozen=True, kw_only=True)
class Posteriors:
    """Rows of posteriors (:func:`posterior` of (R, G) log-likelihoods).

    ``weights`` (R, G): each one's mass on :data:`GRID` (what the test of a trial against
    it integrates over).
    """

    scale: F64
    dof: F64
    information: F64
    at_limit: Bools
    weights: F64
