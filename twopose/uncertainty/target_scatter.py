"""The scatter of a session's trials of one target: evidence on the placing multiplier.

Issue 54 (a new user's r6 G3). The thesis' own procedure, method 2 with two poses a trial,
leaves no misclosure: each trial alone cannot test the placing sigma. A session whose
trials measured **one target** (:func:`twopose.uncertainty.blunders.one_target`) can: its
``T`` estimates ``x_i`` of one point scatter with covariances ``C_i(lambda) = A_i + lambda
B_i`` (``B_i`` the region's part the placing sigma the regions start from gives, first
order and its curvature; ``A_i`` the rest: pixels, rotations, intrinsics), so any ``T - 1``
independent contrasts ``K x`` (here Helmert's) are ``N(0, K A K^T + lambda K B K^T)``
whatever the target. In the generalised eigenbasis of that pair (``B w = beta (A + B)
w``, ``w^T (A + B) w = 1``) each contrast component ``z = w^T K x`` has the variance ``1 +
(lambda - 1) beta``: a misclosure's (share, z^2) exactly
(:func:`twopose.uncertainty.placing_variance.trial_loglik`), so the contrasts enter the same
grid likelihood and posterior beside the trials' misclosures, and sigma0's test. Their
likelihood does not depend on which contrasts are taken (any full-rank set spans the same
space: restricted maximum likelihood, the target's position integrated out).

Regions of rank 2 (a ground point, a line's point across the line) are compared on the
directions they hold (the projector the test of :mod:`twopose.uncertainty.blunders` takes,
the mean of the directions they say nothing about left out): ``k = 2`` components
a trial, ``k = 3`` for a point, ``(T - 1) k`` in all.

**Robust first.** Before pooling, each trial's estimate is tested against the weighted mean
of the others (at the multiplier *their* contrasts, the trials' misclosures, the anchor and
the operator's prior give): the statistic at the rest's multiplier under the rest's
posterior predictive (:func:`twopose.uncertainty.robust_flags.trial_pvalues`), flagged
when both it and the typed model's test reject at :data:`SCATTER_LEVEL`; the worst first,
then again without it, while two others remain. So an operator 3x worse than typed is not
called a typo trial by trial (the old test, in regions at the typed sigma, flagged a third
of such clean trials), and a 1 in typo in one trial still is.

Errors shared by every trial (the calibration's intrinsics, a rig's constants) move the
estimates alike and cancel in the contrasts; the intrinsics stay in ``A`` (the regions hold
them, the pipeline does not split them out), so ``lambda`` is, if anything, understated
there. The contrasts are taken independent of the trials' misclosures (exact for a
least-squares estimate, whose residuals are independent of it). No I/O.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64, Bools
from twopose.uncertainty.blunders import TargetTests, _across
from twopose.uncertainty.noise import PlacingPrior
from twopose.uncertainty.placing_variance import GRID, posterior
from twopose.uncertainty.robust_flags import BAARDA_LEVEL, trial_pvalues

__all__ = ["SCATTER_LEVEL", "Evidence", "TargetScatter", "components", "scatter_tests"]

#: The test's level: Baarda's, as a misclosure's (0.5%), not the 0.1% the test of each
#: trial in regions at the typed sigma took (a 1 in typo beside an operator 3x worse than
#: typed is about 3 of their sigmas: flagged 14 of 30 at 0.1%, 21 of 30 at 0.5%).
SCATTER_LEVEL = BAARDA_LEVEL
#: The least other trials that say where the target is (as the old test's).
_REST_LEAST = 2
#: A direction's variance below this share of the largest is none (a rank-2 region's normal).
_FLAT = 1e-9


@dataclass(frozen=True, kw_only=True)
class Evidence:
    """What the contrasts of some trials of one target say of ``lambda``.

    ``loglik`` and ``info`` (G,) on :data:`~twopose.uncertainty.placing_variance.GRID`;
    ``chi2`` on ``dof``: their sum of squares under the model the regions start from
    (``lambda = 1``); ``trials``: how many trials.
    """

    loglik: F64
    info: F64
    chi2: float
    dof: int
    trials: int


@dataclass(frozen=True, kw_only=True)
class TargetScatter:
    """A session's trials of one target on the directions their regions hold.

    ``y`` (T, k), ``A`` and ``B`` (T, k, k): each trial's estimate and its region's two
    parts (see the module); ``usable`` (T,): of the one target, solved and not flagged by
    its own misclosure. :meth:`evidence` pools the trials not kept ``out``.
    """

    y: F64
    A: F64
    B: F64
    usable: Bools

    def evidence(self, out: Bools) -> Evidence | None:
        """The contrasts of the usable trials not ``out`` (None: fewer than two)."""
        use = self.usable & ~out
        if use.sum() < 2:
            return None
        loglik, info, chi2 = _restricted(_blocks(self.y[use], self.A[use], self.B[use]))
        return Evidence(loglik=loglik[0], info=info[0], chi2=float(chi2[0]),
                        dof=(int(use.sum()) - 1) * self.y.shape[1],
                        trials=int(use.sum()))  # fmt: skip


def components(y: F64, A: F64, B: F64) -> tuple[F64, F64]:
    """(M,) twice: the placing share and squared component of ``n`` estimates' contrasts.

    ``y`` (n, k), ``A``, ``B`` (n, k, k); ``M = (n - 1) k``. Helmert's contrasts, then the
    generalised eigenbasis of their two covariances (see the module). The definition; the
    session's curves are computed without its ``M x M`` matrices (:func:`_restricted`).
    """
    n, k = y.shape
    j = np.arange(1, n)[:, None]
    i = np.arange(n)[None, :]
    H = (np.where(i < j, 1.0, 0.0) - np.where(i == j, j, 0.0)) / np.sqrt(j * (j + 1))
    Ka, Kb = (np.einsum("ai,bi,ipq->apbq", H, H, X).reshape((n - 1) * k, -1) for X in (A, B))
    return _generalised(np.einsum("ai,ip->ap", H, y).reshape(-1), Ka, Kb)


def _blocks(y: F64, A: F64, B: F64) -> dict[str, F64]:
    """Each trial's terms of the restricted likelihood at every multiplier on the grid.

    ``y`` (n, k), ``A``, ``B`` (n, k, k); each (G, n, ...): ``W = C^-1`` (``C = A + lambda
    B``), ``log|C|``, ``W y``, ``y^T W y``, ``tr((W B)^2)``, ``W B W`` and ``W B W B W``.
    """
    C = A[None] + GRID[:, None, None, None] * B[None]
    W = np.linalg.inv(C)
    U = W @ B[None]
    Wy = np.einsum("gnij,nj->gni", W, y)
    return {"W": W, "logdet": np.linalg.slogdet(C)[1], "Wy": Wy,
            "yWy": np.einsum("ni,gni->gn", y, Wy), "UU": np.einsum("gnij,gnji->gn", U, U),
            "Q1": U @ W, "Q2": U @ U @ W}  # fmt: skip


def _restricted(b: dict[str, F64], *, each_left_out: bool = False) -> tuple[F64, F64, F64]:
    """The restricted log-likelihood of ``lambda``, its information, its chi-square at 1.

    (R, G), (R, G) on the grid and (R,): of every trial in ``b`` (:func:`_blocks`), R = 1, or
    with ``each_left_out``, R = n: of every trial but the row's own (the sums less its terms).

    With ``P = W - W X (X^T W X)^-1 X^T W`` (the contrasts' projector, ``X`` the stacked
    identities): ``-1/2 [sum log|C_i| + log|sum W_i| + y^T P y]``, which is the components'
    likelihood (:func:`components`) up to a constant, and ``lambda^2 tr((P B)^2)`` = ``sum
    (lambda beta / (1 + (lambda - 1) beta))^2``, their information, in O(G n k^3).
    """

    def total(x: F64) -> F64:  # (R, G, ...) the trials' sum, less each one's own
        every = x.sum(axis=1, keepdims=True)  # (G, 1, ...)
        return np.moveaxis(every - x if each_left_out else every, 1, 0)

    S0, S1 = total(b["W"]), total(b["Wy"])
    M = np.linalg.inv(S0)
    quad = total(b["yWy"]) - np.einsum("rgi,rgij,rgj->rg", S1, M, S1)
    loglik = -0.5 * (total(b["logdet"]) + np.linalg.slogdet(S0)[1] + quad)
    MQ1 = M @ total(b["Q1"])
    trace = total(b["UU"]) - 2 * np.einsum("rgij,rgji->rg", M, total(b["Q2"]))
    info = GRID**2 * (trace + np.einsum("rgij,rgji->rg", MQ1, MQ1))
    at_one = int(np.argmin(np.abs(np.log(GRID))))
    return loglik, np.clip(info, 0.0, None), quad[:, at_one]


def _generalised(d: F64, A: F64, B: F64) -> tuple[F64, F64]:
    """``d``'s components in the eigenbasis of ``B`` against ``A + B``: (share, z^2)."""
    from scipy import linalg  # here: only a session of one target loads it

    S = A + B
    try:
        beta, W = linalg.eigh(B, S)
    except linalg.LinAlgError:  # singular (a direction no region holds): a tiny ridge
        beta, W = linalg.eigh(B, S + _FLAT * np.trace(S) / len(S) * np.eye(len(S)))
    return np.clip(beta, 0.0, 1.0), (W.T @ d) ** 2


def scatter_tests(
    point: F64,
    parts: F64,
    same: Bools,
    out: Bools,
    base: tuple[F64, F64],
    anchor: PlacingPrior,
    prior: PlacingPrior | None = None,
    *,
    level: float = SCATTER_LEVEL,
) -> tuple[TargetScatter | None, TargetTests]:
    """The trials of one target tested against each other, robustly, and their scatter.

    ``point`` (T, 3), ``parts`` (T, 2, 3, 3): each trial's estimate and its region's two
    parts ``A``, ``B`` at the sigma the regions start from (NaN: not solved); ``same`` (T,)
    the one target's trials; ``out`` (T,): flagged already (never tested here, never in a
    rest); ``base``: the session's evidence on ``lambda`` from its misclosures (each
    unflagged trial's log-likelihood and information, (T, G) each; zero for a flagged
    one): a trial's own misclosure is in no rest it is tested against (left in, a line's
    1 in typo, whose misclosure is mostly pixels, pulled its own rest's multiplier up and
    passed: r6 G8). The scatter is None where fewer than three trials can be compared.
    """
    T = len(point)
    none = TargetTests(flagged=np.zeros(T, dtype=bool), chi2=np.full(T, np.nan),
                       dof=np.zeros(T, dtype=np.int_), p=np.full(T, np.nan),
                       apart=np.full(T, np.nan))  # fmt: skip
    finite = np.asarray(np.isfinite(point).all(axis=1) & np.isfinite(parts).all(axis=(1, 2, 3)))
    usable = same & finite & ~out
    if usable.sum() < _REST_LEAST + 1:
        return None, none
    Q = _basis(_across(parts[usable].sum(axis=1)))
    y = np.where(finite[:, None], np.nan_to_num(point) @ Q, np.nan)
    A, B = (np.einsum("pi,tpq,qj->tij", Q, np.nan_to_num(parts[:, n]), Q) for n in (0, 1))
    scatter = TargetScatter(y=y, A=A, B=B, usable=usable)
    kept = usable.copy()
    flagged = np.zeros(T, dtype=bool)
    stat, dof, p, apart = none.chi2.copy(), none.dof.copy(), none.p.copy(), none.apart.copy()
    while kept.sum() >= _REST_LEAST + 1:
        rows = np.flatnonzero(kept)
        stat[rows], dof[rows], p_typed, p_rest, apart[rows] = _each_against_rest(
            scatter, rows, base, anchor, prior
        )
        p[rows] = np.where(np.isfinite(p_rest), p_rest, p_typed)
        rejects = (p_typed < level) & (np.isnan(p_rest) | (p_rest < level))
        if not rejects.any():
            break
        worst = rows[np.flatnonzero(rejects)[np.argmin(p[rows][rejects])]]
        flagged[worst], kept[worst] = True, False
    # only the usable trials were ever tested: the others keep NaN and 0
    return scatter, TargetTests(flagged=flagged, chi2=stat, dof=dof, p=p, apart=apart)


def _basis(P: F64) -> F64:
    """(3, k) an orthonormal basis of the projector ``P``'s range."""
    w, V = np.linalg.eigh(P)
    return np.asarray(V[:, w > 0.5])


def _each_against_rest(
    s: TargetScatter,
    rows: np.ndarray,
    base: tuple[F64, F64],
    anchor: PlacingPrior,
    prior: PlacingPrior | None,
) -> tuple[F64, np.ndarray, F64, F64, F64]:
    """Each of ``rows`` against the weighted mean of the others (see the module).

    Per row: its statistic at the rest's multiplier, its dof (k), its p-value against the
    typed model and against the rest's predictive, and how far it lies from the rest's mean.
    """
    R, k = len(rows), s.y.shape[1]
    blocks = _blocks(s.y[rows], s.A[rows], s.B[rows])
    rest_L, rest_info, _ = _restricted(blocks, each_left_out=True)
    # the session's misclosures less the trial's own: each row's rest is the others'
    rest_L = rest_L + base[0].sum(axis=0) - base[0][rows]
    rest_info = rest_info + base[1].sum(axis=0) - base[1][rows]
    rest = posterior(rest_L, anchor, prior, rest_info)
    shares, z2s, far = np.zeros((R, k)), np.zeros((R, k)), np.zeros(R)
    for r, i in enumerate(rows):
        others = rows[rows != i]
        lam = float(rest.scale[r])  # type: ignore[index]
        W = np.linalg.inv(s.A[others] + lam * s.B[others])
        M = np.linalg.inv(W.sum(axis=0))
        d = s.y[i] - M @ np.einsum("tij,tj->i", W, s.y[others])
        # the mean's covariance at every lambda: M (sum W C_j W) M, linear in lambda
        Am, Bm = (M @ (W @ X[others] @ W).sum(axis=0) @ M for X in (s.A, s.B))
        shares[r], z2s[r] = _generalised(d, s.A[i] + Am, s.B[i] + Bm)
        far[r] = float(np.linalg.norm(d))
    dof = np.full(R, k, dtype=np.int_)
    at_one = int(np.argmin(np.abs(np.log(GRID))))
    beside = rest_info[:, at_one] + (prior.dof if prior and math.isfinite(prior.dof) else 0.0)
    chi2 = z2s.sum(axis=1)
    p_typed, p_rest = trial_pvalues(chi2, dof, shares, z2s, rest, beside)  # type: ignore[arg-type]
    scale = np.asarray(rest.scale)
    under = (z2s / (1.0 + (scale[:, None] - 1.0) * shares)).sum(axis=1)
    return under, dof, p_typed, p_rest, far
