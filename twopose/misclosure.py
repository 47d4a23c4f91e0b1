"""Each trial's misclosure: how far its views disagree with its own estimate (issue 46).

A trial with more measurements than its estimate has parameters carries **redundancy**: a
point seen from N poses has 2N pixel coordinates for 3 unknowns (2N - 3 redundant), a line
or the finger's line from N image lines has 2N numbers for 4 unknowns (2N - 4, so N >= 3).
Its **residuals** are each view's measurement minus what the estimate predicts there (the
point projected; the 3-D line projected: the centroid's distance across it and its
angle). Under the noise model (the same input covariance the regions assume: frame
scatter and detector floor, placing sigma, calibration sigma) they have the covariance
``Cov(r) = J_r C J_r^T``, from the perturbation machinery of
:func:`twopose.uncertainty.propagate` (:func:`twopose.uncertainty.jacobians`);
``chi2 = r^T Cov(r)^+ r`` on its ``dof`` redundant
directions is chi-square with ``dof`` degrees of freedom when the model is right, whatever
the estimator (to first order, the residual is an oblique projection of the input error).

Pooled over a session, :func:`pooled` gives photogrammetry's a-posteriori variance factor
(:class:`twopose.noise.VarianceFactor`), and the placing variance's multiplier ``lambda``
by variance component estimation (:func:`placing_component`): ``Cov(r) = A + lambda B``,
``B`` the part the placing sigma gives (``A`` the rest: pixels, rotation, calibration),
``lambda`` the maximum of the trials' joint Gaussian likelihood. In each trial's basis
that whitens ``A + B`` and diagonalizes ``B`` (``B``'s shares ``beta`` in 0..1, the
residual's components ``z``) the likelihood is a sum of scalars,
``-1/2 sum [log(1 + (lambda - 1) beta) + z^2 / (1 + (lambda - 1) beta)]``; when the data
contradict ``lambda = 1`` every region is propagated from :func:`placed`'s input covariance.
What a solver predicts of a view (rays or planes) is named by the solver table
(:mod:`twopose.estimate`), never by a method's name.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from twopose.arrays import F64, Bools, Ints
from twopose.detect import wrap_theta_deg
from twopose.noise import VarianceFactor
from twopose.solve import image_lines, triangulate_lines, triangulate_points
from twopose.uncertainty import PLACING, Shared, jacobians, region_dof

__all__ = [
    "PLANES",
    "RAYS",
    "Misclosure",
    "MisclosureModel",
    "misclosures",
    "placed",
    "placing_component",
    "pooled",
    "region_widening",
    "widened",
    "widening_of",
]

#: Each view's residuals from the (perturbed) inputs ``x`` (R, N, 9[+S]), their cameras
#: ``P`` (R, N, 3, 4) and valid views (R, N): (R, N, 2), zero in a padding view.
Residuals = Callable[[F64, F64, Bools], F64]
#: Eigen-directions of Cov(r) under this share of its largest are outside its range.
_RANK_TOLERANCE = 1e-9
#: The placing variance's multipliers searched: a placing sigma 1/4 to 8 times the typed.
LAMBDA_RANGE = (1.0 / 16.0, 64.0)


@dataclass(frozen=True, kw_only=True)
class MisclosureModel:
    """What a solver's estimate predicts of each view, and how many parameters it has."""

    residuals: Residuals
    #: The estimate's degrees of freedom: a point 3, a 3-D line 4.
    parameters: int


def _project(P: F64, X: F64) -> F64:
    """(R, N, 2) the points ``X`` (R, 3) (or (R, N, 3)) in each view's pixels."""
    Xh = np.concatenate([X, np.ones((*X.shape[:-1], 1))], axis=-1)
    if Xh.ndim == 2:
        Xh = np.broadcast_to(Xh[:, None], (*P.shape[:2], 4))
    h = np.einsum("rnij,rnj->rni", P, Xh)
    return np.asarray(h[..., :2] / h[..., 2:3])


def ray_residuals(x: F64, P: F64, valid: Bools) -> F64:
    """Each view's measured pixel minus the thesis' point projected there (R, N, 2)."""
    X = triangulate_points(x[..., :2], P, valid=valid).point_grid
    r = x[..., :2] - _project(P, X)
    return np.asarray(np.where(valid[..., None], r, 0.0))


def plane_residuals(x: F64, P: F64, valid: Bools) -> F64:
    """Each view's centroid across, and angle against, the thesis' 3-D line projected.

    (R, N, 2): the measured centroid's signed distance (px) from the projected line and
    the measured angle minus the projected line's (degrees, lines have no arrow).
    """
    line = triangulate_lines(image_lines(x[..., :2], x[..., 2]), P, valid=valid)
    a = _project(P, line.point_grid)
    b = _project(P, line.point_grid[:, None] + line.direction_grid[:, None])
    d = b - a
    length = np.linalg.norm(d, axis=-1, keepdims=True)
    normal = np.stack([-d[..., 1], d[..., 0]], axis=-1) / length
    across = np.einsum("rni,rni->rn", x[..., :2] - a, normal)
    angle = wrap_theta_deg(x[..., 2] - np.degrees(np.arctan2(d[..., 1], d[..., 0])))
    r = np.stack([across, angle], axis=-1)
    return np.asarray(np.where(valid[..., None], r, 0.0))


#: A point's rays: its projection in every view.
RAYS = MisclosureModel(residuals=ray_residuals, parameters=3)
#: A line's planes (the fixed line, method 2's finger): the line projected in every view.
PLANES = MisclosureModel(residuals=plane_residuals, parameters=4)


@dataclass(frozen=True, kw_only=True)
class Misclosure:
    """Per trial: the misclosure's chi-square and its degrees of freedom (0: none)."""

    chi2: F64  # (T,) NaN where the trial has no redundancy or no finite residual
    dof: Ints  # (T,)
    #: (T, 2N) the placing's share ``beta`` of each whitened direction of Cov(r), and the
    #: residual's squared component there (zero: outside its range); ``chi2`` their sum.
    placing_share: F64
    z2: F64


def misclosures(
    residuals: Callable[[F64], F64],
    inputs: F64,
    input_cov: F64,
    valid: Bools,
    parameters: int,
    *,
    shared: Shared | None = None,
) -> Misclosure:
    """Every trial's misclosure chi-square, vectorized over trials.

    ``residuals`` maps stacked (perturbed) inputs (R T, N, 9[+S]) to (R T, N, 2) as
    :func:`twopose.uncertainty.propagate` calls an estimate; ``inputs`` (T, N, 9),
    ``input_cov`` (T, N, 9, 9), ``shared`` as there; ``parameters``: the estimate's own.
    """
    T, N, _ = inputs.shape
    M = 2 * N
    r = residuals(inputs).reshape(T, M)

    def flat(x: F64) -> F64:
        return residuals(x).reshape(x.shape[0], M)

    J, Js = jacobians(flat, inputs, input_cov, M, shared=shared)
    cov = np.einsum("tinj,tnjk,tlnk->til", J, input_cov, J)
    Jp = J[..., PLACING]
    placing = np.einsum("tinj,tnjk,tlnk->til", Jp, input_cov[..., PLACING, PLACING], Jp)
    if Js is not None and shared is not None:
        cov = cov + np.einsum("tigs,tgsr,tjgr->tij", Js, shared.cov, Js)
    dof = np.clip(2 * valid.sum(axis=1) - parameters, 0, None).astype(np.int_)
    chi2 = np.full(T, np.nan)
    share, z2 = np.zeros((T, M)), np.zeros((T, M))
    good = (dof > 0) & np.isfinite(r).all(axis=1) & np.isfinite(cov).all(axis=(1, 2))
    if good.any():
        parts = _components(r[good], cov[good], placing[good], dof[good])
        chi2[good], share[good], z2[good], dof[good] = parts
    tested = np.isfinite(chi2) & (dof > 0)
    return Misclosure(
        chi2=np.where(tested, chi2, np.nan),
        dof=np.where(tested, dof, 0),
        placing_share=np.where(tested[:, None], share, 0.0),
        z2=np.where(tested[:, None], z2, 0.0),
    )


def _components(r: F64, cov: F64, placing: F64, dof: Ints) -> tuple[F64, F64, F64, Ints]:
    """Each residual in the basis that whitens ``cov`` and diagonalizes its ``placing`` part.

    Over each covariance's ``dof`` largest directions (its range): the directions the
    model gives no noise are left out (exact inputs: nothing to test), their count the
    chi-square's degrees of freedom. Returns ``chi2 = r^T Cov^+ r``, the placing's share of
    each direction (0..1), the residual's squared component there (their sum is ``chi2``),
    and the count.
    """
    w, V = np.linalg.eigh(cov)  # ascending
    M = w.shape[1]
    rank = np.arange(M)[None, :] >= (M - dof)[:, None]
    keep = rank & (w > _RANK_TOLERANCE * np.abs(w[:, -1:])) & (w > 0)
    along = np.einsum("tji,tj->ti", V, r)
    safe = np.where(keep, w, 1.0)
    chi2 = np.where(keep, along**2 / safe, 0.0).sum(axis=1)
    scale = np.where(keep, 1.0 / np.sqrt(safe), 0.0)
    Q = V * scale[:, None, :]  # whitening of the range, zero outside it
    beta, U = np.linalg.eigh(np.einsum("tji,tjk,tkl->til", Q, placing, Q))
    z = np.einsum("tki,tk->ti", U, along * scale)
    return chi2, np.clip(beta, 0.0, 1.0), z**2, keep.sum(axis=1).astype(np.int_)


def _neg_log_likelihood(lam: F64, beta: F64, z2: F64) -> F64:
    """``-log L`` (up to a constant) of each multiplier ``lam`` (G,) given (K,) components."""
    d = 1.0 + (np.asarray(lam)[..., None] - 1.0) * beta
    return np.asarray(0.5 * (np.log(d) + z2 / d).sum(axis=-1))


def placing_component(beta: F64, z2: F64) -> tuple[float, float, float]:
    """The placing variance's multiplier ``lambda`` by maximum likelihood, and its test.

    ``beta``, ``z2``: the placing's shares and the residuals' squared components of the
    pooled trials' directions (any shape). A log-spaced grid over :data:`LAMBDA_RANGE`,
    then Brent's bounded search between the best point's neighbours. Returns ``lambda``,
    the likelihood-ratio statistic ``2 (log L(lambda) - log L(1))`` and the degrees of
    freedom ``lambda`` is estimated from, ``sum (lambda beta / (1 + (lambda - 1) beta))^2``
    (``2 lambda^2`` times its Fisher information, so that ``Var(lambda) = 2 lambda^2 / f``
    as for a variance from ``f`` degrees of freedom); NaN without a placing direction.
    """
    from scipy.optimize import minimize_scalar

    use = np.asarray(beta).ravel() > 0
    b, z = np.asarray(beta).ravel()[use], np.asarray(z2).ravel()[use]
    if not b.size:
        return math.nan, math.nan, math.nan
    grid = np.geomspace(*LAMBDA_RANGE, 41)
    values = _neg_log_likelihood(grid, b, z)
    g = int(np.argmin(values))
    lam, best = float(grid[g]), float(values[g])
    if 0 < g < len(grid) - 1:
        fit = minimize_scalar(
            lambda x: float(_neg_log_likelihood(np.asarray(x), b, z)),
            bounds=(grid[g - 1], grid[g + 1]),
            method="bounded",
            options={"xatol": 1e-4 * lam},
        )
        if float(fit.fun) < best:
            lam, best = float(fit.x), float(fit.fun)
    lr = 2.0 * (float(_neg_log_likelihood(np.asarray(1.0), b, z)) - best)
    f = float(((lam * b / (1.0 + (lam - 1.0) * b)) ** 2).sum())
    return lam, max(lr, 0.0), f


def pooled(m: Misclosure, rows: NDArray[np.bool_] | None = None) -> VarianceFactor:
    """The a-posteriori variance factor of a session's trials (``rows``: which; all).

    ``sigma0^2 = sum chi2 / sum dof`` over the trials with redundancy, and the placing
    variance's multiplier from their components (:func:`placing_component`).
    """
    use = np.isfinite(m.chi2) & (m.dof > 0)
    if rows is not None:
        use &= rows
    dof = int(m.dof[use].sum())
    if dof == 0:
        return VarianceFactor(sigma0_sq=float("nan"), dof=0, trials=0)
    sigma0_sq = float(m.chi2[use].sum() / dof)
    lam, lr, f = placing_component(m.placing_share[use], m.z2[use])
    return VarianceFactor(
        sigma0_sq=sigma0_sq,
        dof=dof,
        trials=int(use.sum()),
        placing_scale=math.sqrt(lam),
        placing_dof=f,
        placing_lr=lr,
    )


def placed(cov_in: F64, factor: VarianceFactor | None) -> F64:
    """The input covariance (T, N, 9, 9) with the placing variance times ``lambda``.

    (:attr:`twopose.noise.VarianceFactor.placing_variance`; unchanged when the data agree
    with the model): every region, fit and direction is propagated from it again.
    """
    if factor is None or factor.placing_variance == 1.0:
        return cov_in
    out = cov_in.copy()
    out[..., PLACING, PLACING] *= factor.placing_variance
    return out


def region_widening(cov: F64, model: F64) -> F64:
    """(T,) each region's largest variance in ``cov`` against ``model``'s (NaN: not finite).

    1 exactly where the two are the same: the data agreed with the model.
    """
    out = np.full(len(cov), np.nan)
    finite = np.isfinite(cov).all(axis=(1, 2)) & np.isfinite(model).all(axis=(1, 2))
    if finite.any():
        new, old = np.linalg.eigvalsh(cov[finite])[:, -1], np.linalg.eigvalsh(model[finite])[:, -1]
        with np.errstate(invalid="ignore", divide="ignore"):
            out[finite] = np.where(new == old, 1.0, new / old)
    return out


def widened(cov: F64, factor: VarianceFactor | None) -> F64:
    """Covariances (T, 3, 3) widened by a contradicted ``factor`` (unchanged otherwise).

    Propagated already with the measured placing sigma (:func:`placed`),
    each is multiplied by :func:`widening_of`, the F quantile for ``lambda`` estimated
    from few degrees of freedom, so every column and figure reads the widened region.
    """
    if factor is None or not factor.contradicted or not len(cov):
        return cov
    return np.asarray(cov * widening_of(cov, factor)[:, None, None])


def widening_of(cov: F64, factor: VarianceFactor | None) -> F64:
    """(T,) each covariance's multiplier (1: unchanged; NaN: no finite covariance).

    :meth:`VarianceFactor.widening` for its region's own dimensions
    (:func:`twopose.uncertainty.region_dof`: 3 for a point, 2 for a ground point or a
    line's point). Widening keeps the dimensions: a widened covariance gives its own.
    """
    k = region_dof(cov)
    scale = np.where(k > 0, 1.0, np.nan)
    if factor is not None and factor.contradicted:
        for dims in np.unique(k[k > 0]):
            scale[k == dims] = factor.widening(int(dims))
    return scale
