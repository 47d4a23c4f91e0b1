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
(:class:`twopose.noise.VarianceFactor`). What a solver predicts of a view (rays or planes)
is named by the solver table (:mod:`twopose.estimate`), never by a method's name.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from twopose.arrays import F64, Bools, Ints
from twopose.detect import wrap_theta_deg
from twopose.noise import VarianceFactor
from twopose.solve import image_lines, triangulate_lines, triangulate_points
from twopose.uncertainty import Shared, jacobians

__all__ = [
    "PLANES",
    "RAYS",
    "Misclosure",
    "MisclosureModel",
    "misclosures",
    "pooled",
]

#: Each view's residuals from the (perturbed) inputs ``x`` (R, N, 9[+S]), their cameras
#: ``P`` (R, N, 3, 4) and valid views (R, N): (R, N, 2), zero in a padding view.
Residuals = Callable[[F64, F64, Bools], F64]
#: Eigen-directions of Cov(r) under this share of its largest are outside its range.
_RANK_TOLERANCE = 1e-9


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
    if Js is not None and shared is not None:
        cov = cov + np.einsum("tigs,tgsr,tjgr->tij", Js, shared.cov, Js)
    dof = np.clip(2 * valid.sum(axis=1) - parameters, 0, None).astype(np.int_)
    chi2 = np.full(T, np.nan)
    good = (dof > 0) & np.isfinite(r).all(axis=1) & np.isfinite(cov).all(axis=(1, 2))
    if good.any():
        chi2[good], dof[good] = _chi2(r[good], cov[good], dof[good])
    tested = np.isfinite(chi2) & (dof > 0)
    return Misclosure(chi2=np.where(tested, chi2, np.nan), dof=np.where(tested, dof, 0))


def _chi2(r: F64, cov: F64, dof: Ints) -> tuple[F64, Ints]:
    """``r^T Cov^+ r`` over each covariance's ``dof`` largest directions (its range).

    With the directions the model gives no noise left out (exact inputs: nothing to test),
    and their count: the chi-square's degrees of freedom.
    """
    w, V = np.linalg.eigh(cov)  # ascending
    M = w.shape[1]
    rank = np.arange(M)[None, :] >= (M - dof)[:, None]
    keep = rank & (w > _RANK_TOLERANCE * np.abs(w[:, -1:])) & (w > 0)
    z = np.einsum("tji,tj->ti", V, r)
    with np.errstate(divide="ignore", invalid="ignore"):
        chi2 = np.where(keep, z**2 / w, 0.0).sum(axis=1)
    return np.asarray(chi2), keep.sum(axis=1).astype(np.int_)


def pooled(m: Misclosure, rows: NDArray[np.bool_] | None = None) -> VarianceFactor:
    """The a-posteriori variance factor of a session's trials (``rows``: which; all).

    ``sigma0^2 = sum chi2 / sum dof`` over the trials with redundancy.
    """
    use = np.isfinite(m.chi2) & (m.dof > 0)
    if rows is not None:
        use &= rows
    dof = int(m.dof[use].sum())
    if dof == 0:
        return VarianceFactor(sigma0_sq=float("nan"), dof=0, trials=0)
    return VarianceFactor(sigma0_sq=float(m.chi2[use].sum() / dof), dof=dof, trials=int(use.sum()))
