"""The operator's placing sigma from a board fit's linearization (issues 46 and 55).

A board fit (:func:`twopose.rig.board.fit_board_rig`) carries, per capture, where the laptop
really stood (three placing errors, prior sigma ``s``) and how it was really turned (three
rotation errors, prior sigma the typed rotation resolution: known, not estimated), beside
the rig's constants (their physical priors). On the fit's linearization (whitened corners:
``res + J (x - p)``, the parameters ``x`` with a Gaussian prior about ``m``), the corners'
marginal likelihood of ``s``, every other parameter integrated out, is

    log L(s) = -1/2 [ -g^T A^-1 g + log det A + log det D(s) ] + const,
    A = D(s)^-1 + J^T J,  g = J^T (J (p - m) - res),

(Woodbury and the determinant lemma: only P x P matrices). Its maximum is found by EM
(:func:`placing_em`: ``s^2`` = the mean over the placing components of each one's posterior
mean squared plus its posterior variance), and its 1-sigma from the Fisher information,
``s / sqrt(2 dof)``, ``dof = tr(H^2)``, ``H = I - V / s^2`` with ``V`` the placing errors'
posterior covariance: what the corners determine of them, less what the constants and the
rotation errors absorb. A rotation about the camera's x or y axis moves a board's image
much as a sideways placing error does; modelled, it no longer reads as placing (issue 54:
0.2 degrees typed honestly had inflated the measured sigma by a third).

Where the maximum is at the floor (the captures show no placing error their corners
resolve: a synthetic board placed exactly, say), or rests on fewer than
:data:`twopose.uncertainty.noise.MIN_PLACING_DOF` degrees of freedom, the placing sigma is not
measured:
:func:`placing_upper_bound` gives the most it can be, the one-sided 95% profile-likelihood
bound (``2 [log L(s_hat) - log L(s)] = chi2_1(90%)``, the boundary's half-and-half
mixture), which a rig file writes as an upper bound, never as a measurement. No I/O.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64

__all__ = ["EM_ROUNDS", "PLACING_FLOOR_IN", "Linearized", "placing_em", "placing_upper_bound"]

#: EM's rounds on one linearization (each a (P, P) inverse; it converges in tens).
EM_ROUNDS = 500
#: The smallest placing sigma EM reports (inches): below what any tape and hand can place,
#: and kept off zero, which EM approaches without reaching. A sigma there is the fit's
#: floor, not a measurement (:func:`placing_upper_bound`).
PLACING_FLOOR_IN = 1e-3
#: The one-sided 95% bound's drop in log-likelihood: half chi-square's 90% quantile (1 dof).
_BOUND_DROP = 0.5 * 2.705543454095404


@dataclass(frozen=True, kw_only=True)
class Linearized:
    """A board fit's linearization, for the placing sigma.

    ``jac`` (N, P) and ``res`` (N,): the whitened corners' Jacobian and residuals at the
    fitted parameters ``p`` (P,), whose prior means are ``nominal``; ``prior(s)`` (P,) each
    parameter's prior sigma when the placing sigma is ``s``; ``placing`` the indices of
    the placing errors among the P parameters.
    """

    jac: F64
    res: F64
    p: F64
    nominal: F64
    prior: Callable[[float], F64]
    placing: slice

    def posterior(self, s: float) -> tuple[F64, F64, F64]:
        """The parameters' posterior precision ``A`` (P, P), its inverse and mean, at ``s``."""
        precision = self.prior(s) ** -2.0
        a = self.jac.T @ self.jac + np.diag(precision)
        a_inv: F64 = np.asarray(np.linalg.inv(a), dtype=np.float64)
        grad = self.jac.T @ self.res
        mean = self.p - a_inv @ (grad + precision * (self.p - self.nominal))
        return a, a_inv, mean

    def log_likelihood(self, s: float) -> float:
        """The corners' marginal log-likelihood of the placing sigma ``s`` (module docs)."""
        a, a_inv, _ = self.posterior(s)
        z = self.jac @ (self.p - self.nominal) - self.res
        g = self.jac.T @ z
        _, logdet_a = np.linalg.slogdet(a)
        logdet_d = 2.0 * float(np.sum(np.log(self.prior(s))))
        return -0.5 * (-float(g @ a_inv @ g) + float(logdet_a) + logdet_d)


def placing_em(lin: Linearized, s: float, floor: float) -> tuple[float, float]:
    """The placing sigma that maximises the marginal likelihood (EM), from ``s``.

    Returns the sigma (at least ``floor``) and its degrees of freedom ``tr(H^2)`` (module
    docs), so that the estimate's 1-sigma is ``s / sqrt(2 dof)``.
    """
    dof = 0.0
    for _ in range(EM_ROUNDS):
        _, a_inv, mean = lin.posterior(s)
        e, v = mean[lin.placing], a_inv[lin.placing, lin.placing]
        new_s = max(float(np.sqrt(np.mean(e**2 + np.diag(v)))), floor)
        h = np.eye(len(e)) - v / new_s**2  # what the corners determine of each error
        dof = float(np.sum(h * h.T))  # tr(H^2): the Fisher information's 2 s^4 I(s^2)
        if abs(new_s / s - 1) < 1e-4:
            return new_s, dof
        s = new_s
    return s, dof


def placing_upper_bound(lin: Linearized, s_hat: float, ceiling: float) -> float:
    """The one-sided 95% upper bound of the placing sigma (profile likelihood; module docs).

    From the maximum ``s_hat`` up; ``ceiling`` when the likelihood has not dropped enough
    below it (the corners say nothing up to there).
    """
    from scipy.optimize import brentq

    top = lin.log_likelihood(s_hat)

    def drop(s: float) -> float:
        return top - lin.log_likelihood(s) - _BOUND_DROP

    high = s_hat
    while high < ceiling:
        low, high = high, min(2.0 * high, ceiling)
        if drop(high) > 0:
            return float(brentq(drop, low, high, xtol=1e-6 * high))
    return float(ceiling) if math.isfinite(ceiling) else float(high)
