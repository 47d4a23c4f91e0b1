"""Uncertainty: a covariance for every estimate, and what dominates it.

The inputs of a trial are, per view, ``[col, row, theta_deg, tx, ty, tz, rx_deg, ry_deg,
rz_deg]``: the combined pixel measurement and the typed pose. Views are independent; within
a view the pixel part's 3x3 covariance comes from the frame-to-frame scatter of its frames
and the detector's systematic error, which averaging does not shrink
(:func:`measurement_covariance`), and the pose part is diagonal, from the 1-sigma resolution
recorded with each typed entry. A camera's intrinsics ``(fx, fy, cx, cy)`` are inputs too
when its calibration's 1-sigma is known (:class:`Shared`): their error is the same in every
view that camera took, so they are perturbed in all of a trial's views of that camera at
once. :func:`propagate` pushes that through any batched estimator by central differences
(``Sigma_x = J Sigma_in J^T``), so the covariance follows exactly the code that made the
estimate, thesis formulas or not. With ``second_order`` (every region of a session,
:data:`SECOND_ORDER`) each input is also stepped :data:`SIGMA_POINT_STEP` sigma, a sigma
point, and the variance its curvature adds is added (the second-order term of the
unscented transform's and the divided-difference filter's axis points): exact for an
estimate quadratic in each input, the first-order covariance where it is linear, never
less. No I/O.

(Near 600 lines: the first and the second order share one difference machinery, and the
regions' dimensions, quantiles and NEES read what it gives.)
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass
from statistics import NormalDist

import numpy as np
from numpy.typing import NDArray

from twopose.arrays import F64
from twopose.detect.detection import wrap_theta_deg

__all__ = [
    "CHI2_3DOF_95",
    "CHI2_95",
    "INPUTS_PER_VIEW",
    "INPUT_GROUPS",
    "PLACING",
    "SECOND_ORDER",
    "SHARED_INPUTS",
    "SIGMA_POINT_STEP",
    "SPREAD_COLUMNS",
    "Propagated",
    "Shared",
    "chi2_95",
    "dominant_input",
    "enough_frames",
    "frame_scatter",
    "jacobians",
    "measurement_covariance",
    "nees",
    "pooled_scatter",
    "propagate",
    "region_dof",
    "region_widening",
    "semiaxis95",
    "uncertainty_columns",
]


#: Per-view input layout of :func:`propagate`.
INPUTS_PER_VIEW = ("col", "row", "theta_deg", "tx", "ty", "tz", "rx_deg", "ry_deg", "rz_deg")
#: The inputs the placing sigma is the 1-sigma of: each view's typed translation.
PLACING = slice(3, 6)
#: The 95% quantile of chi-square with 3 degrees of freedom: a full-rank 95% ellipsoid is
#: ``e^T Sigma^-1 e <= CHI2_3DOF_95`` (a region of fewer dimensions: :data:`CHI2_95`).
CHI2_3DOF_95 = 7.814727903251178
#: Input groups for "which input dominates": slices of the per-view layout.
_GROUPS = (
    ("pixels", slice(0, 3)),
    ("x", slice(3, 4)),
    ("y", slice(4, 5)),
    ("z", slice(5, 6)),
    ("rotation", slice(6, 9)),
)
#: The inputs a trial's views of one camera share (:class:`Shared`): its intrinsics.
SHARED_INPUTS = ("fx", "fy", "cx", "cy")
#: The divided differences' step (``second_order``), in each input's sigma: sqrt(3), the
#: Gauss-Hermite point where a normal input's fourth moment is matched (Norgaard, Poulsen
#: and Ravn 2000, "New developments in state estimation for nonlinear systems", DD2).
SIGMA_POINT_STEP = math.sqrt(3.0)
#: Each input's curvature ``f(x + h) + f(x - h) - 2 f(x)`` times this is its second-order
#: column: ``sqrt(h^2 - 1) / (2 h^2)`` (``f = a x + b x^2``: ``Var = a^2 s^2 + 2 b^2 s^4``).
CURVATURE_WEIGHT = math.sqrt(SIGMA_POINT_STEP**2 - 1.0) / (2.0 * SIGMA_POINT_STEP**2)
#: Every region of a session is propagated to second order (``second_order``): the same
#: as first order where the estimate is linear in an input (the thesis' point, line and
#: ground point are linear in the poses' translations), wider where it bends (the
#: rotations, the intrinsics, the pixels; docs/uncertainty.md).
SECOND_ORDER = True
#: Prior weight (pseudo frame-differences) of the session's pooled scatter in each pose's
#: estimate: five frames give four differences, too few to trust a pose's scatter alone.
PRIOR_DOF = 4.0


def frame_scatter(centroids_px: F64, thetas_deg: F64, used: NDArray[np.bool_]) -> tuple[F64, int]:
    """Sample covariance (3, 3) of one pose's used frames and its degrees of freedom.

    Orientation deviations are taken around the doubled-angle mean (lines have no arrow);
    a dot has no orientation, so its row and column are zero.
    """
    c = centroids_px[used]
    k = c.shape[0]
    S = np.zeros((3, 3))
    if k < 2:
        return S, 0
    th = thetas_deg[used]
    if np.isfinite(th).all():
        t2 = np.deg2rad(2.0 * th)
        mean = 0.5 * math.degrees(math.atan2(np.sin(t2).mean(), np.cos(t2).mean()))
        dev = wrap_theta_deg(th - mean)
    else:
        dev = np.zeros(k)
    X = np.column_stack([c, dev])
    S = np.cov(X, rowvar=False, ddof=1)
    return np.asarray(S), k - 1


def pooled_scatter(scatters: list[tuple[F64, int]]) -> F64:
    """The session's pooled within-pose covariance (3, 3): one camera, one noise process."""
    dof = sum(d for _, d in scatters)
    if dof == 0:
        return np.zeros((3, 3))
    return np.asarray(sum(S * d for S, d in scatters) / dof)


def measurement_covariance(
    scatter: F64,
    dof: int,
    pooled: F64,
    n_used: int,
    *,
    median: bool = False,
    floor: tuple[float, float] = (0.0, 0.0),
) -> F64:
    """Covariance (3, 3) of a pose's combined measurement.

    The pose's own scatter is shrunk toward the session's pooled scatter (weight
    :data:`PRIOR_DOF`), then divided by the frames averaged; a median costs pi/2 in variance.
    The detector's ``floor`` (centroid px, orientation degrees; 1-sigma:
    :attr:`twopose.methods.specs.MethodSpec.detector_floor`) is added whatever the frames: the
    same in each of them, averaging leaves it.
    """
    shrunk = (PRIOR_DOF * pooled + dof * scatter) / (PRIOR_DOF + dof)
    factor = (math.pi / 2 if median else 1.0) / max(n_used, 1)
    px, deg = floor
    return np.asarray(shrunk * factor + np.diag([px**2, px**2, deg**2]))


#: Adaptive frames: a pose's capture stops once another frame would shrink its measurement's
#: variance by less than this share (:func:`enough_frames`).
FRAME_GAIN = 0.05
#: ... but never before this many frames were found (the scatter of fewer is no estimate).
LEAST_FRAMES = 3


def enough_frames(
    centroids_px: F64,
    thetas_deg: F64 | None,
    floor: tuple[float, float],
    *,
    gain: float = FRAME_GAIN,
) -> bool:
    """Whether a pose has frames enough: another would not shrink its measurement by ``gain``.

    ``centroids_px`` (K, 2) and ``thetas_deg`` (K,) are the pose's found frames (None: the
    method has no orientation, the dot's blob's is noise). Averaging K frames leaves the
    scatter S over K plus the detector's ``floor`` squared (:func:`measurement_covariance`);
    frame K + 1 takes S / (K (K + 1)) off it. Once that is below ``gain`` of what is left,
    in the centroid's and the orientation's variance alike, more frames no longer shrink the
    region (the floor dominates). Never before :data:`LEAST_FRAMES` frames.
    """
    k = len(centroids_px)
    if k < LEAST_FRAMES:
        return False
    thetas = np.full(k, np.nan) if thetas_deg is None else thetas_deg
    S, _ = frame_scatter(centroids_px, thetas, np.ones(k, dtype=bool))
    scatter = np.diag(S)
    px, deg = floor
    left = scatter / k + np.array([px**2, px**2, deg**2])
    taken = scatter / (k * (k + 1))
    return bool(np.all(taken <= gain * left))


@dataclass(frozen=True, kw_only=True)
class Shared:
    """Inputs common to several views of a trial.

    A camera's intrinsics, whose calibration error is one draw for every view (and every
    trial) that camera took.

    Views of one ``group`` (a trial's views of one camera) hold the same ``values`` and
    are perturbed together; a view in group -1, or a group whose ``cov`` is zero, is exact.
    """

    values: F64  # (T, N, S) each view's values, in the SHARED_INPUTS layout
    group: NDArray[np.int_]  # (T, N) each view's group, 0 .. G-1 (-1: none)
    cov: F64  # (T, G, S, S) each group's covariance


@dataclass(frozen=True, kw_only=True)
class Propagated:
    """First-order covariances of a batch of estimates (see :func:`propagate`)."""

    cov_grid: F64  # (T, 3, 3) covariance of the estimate, grid frame, session units^2
    jacobian: F64  # (T, 3, N, 9) d estimate / d input
    variance_by_group: F64  # (T, N, 5) trace share of pixels, x, y, z, rotation per view
    shared_jacobian: F64 | None = None  # (T, 3, G, S) d estimate / d shared input
    shared_variance: F64 | None = None  # (T,) trace share of the shared inputs
    #: (T, 3, N, 9) each input's second-order column ``c`` (``second_order``): the
    #: covariance's second-order part is ``sum c c^T``, that of the placing's inputs
    #: grows with the placing variance squared (None: first order).
    curvature: F64 | None = None


def _jacobians(
    estimate: Callable[[F64], F64],
    x: F64,
    C: F64,
    shared: Shared | None,
    Cs: F64,
    rel_step: float,
    width: int = 3,
    *,
    second_order: bool = False,
) -> tuple[F64, F64, F64, F64]:
    """The estimate's derivatives by central differences, and its curvature.

    Per view (T, W, N, D) and per shared group (T, W, G, S), W the estimate's ``width``;
    steps of ``rel_step`` sigma. With ``second_order``, each input's curvature beside
    (else zero): ``f(x + h) + f(x - h) - 2 f(x)``, ``h`` :data:`SIGMA_POINT_STEP` sigma
    (zero in a row where those steps leave the solver's domain: NaN).
    """
    T, N, D = x.shape
    sigma = np.sqrt(np.clip(np.diagonal(C, axis1=2, axis2=3), 0.0, None))  # (T, N, 9)
    J, K = np.zeros((T, width, N, D)), np.zeros((T, width, N, D))
    # An exact input (or an unused one: a dot's angle) contributes nothing: skip it.
    columns: list[_Column] = [
        (n, d, None) for n in range(N) for d in range(D) if (sigma[:, n, d] > 0).any()
    ]
    group_sigma = np.sqrt(np.clip(np.diagonal(Cs, axis1=2, axis2=3), 0.0, None))  # (T, G, S)
    Js, Ks = np.zeros((T, width, *Cs.shape[1:3])), np.zeros((T, width, *Cs.shape[1:3]))
    if shared is not None:
        x = np.concatenate([x, np.asarray(shared.values, dtype=np.float64)], axis=-1)
        G, S = Cs.shape[1], Cs.shape[2]
        columns += [
            (g, D + s, shared.group == g)
            for g in range(G)
            for s in range(S)
            if (group_sigma[:, g, s] > 0).any()
        ]
    centre = None
    if second_order:
        with np.errstate(invalid="ignore", divide="ignore"):
            centre = np.asarray(estimate(x), dtype=np.float64).reshape(T, width)
    # All perturbed copies go through the estimator together, in batches of about 2e5
    # views: one vectorized call per batch instead of 2 N D calls.
    per_batch = max(1, 200_000 // max(2 * T * N, 1))
    for start in range(0, len(columns), per_batch):
        batch = columns[start : start + per_batch]
        sigmas = [sigma[:, n, d] if views is None else group_sigma[:, n, d - D]
                  for n, d, views in batch]  # fmt: skip
        slopes = _difference_columns(estimate, x, [rel_step * s for s in sigmas], batch)
        curves = [np.zeros_like(c) for c, _ in slopes]
        if centre is not None:  # a wide step out of the solver's domain: no curvature seen
            wide = _difference_columns(
                estimate, x, [SIGMA_POINT_STEP * s for s in sigmas], batch, centre
            )
            curves = [np.where(np.isfinite(c), c, 0.0) for _, c in wide]
        for (n, d, views), (column, _), curve in zip(batch, slopes, curves, strict=True):
            if views is None:
                J[:, :, n, d], K[:, :, n, d] = column, curve
            else:
                Js[:, :, n, d - D], Ks[:, :, n, d - D] = column, curve
    return J, Js, K, Ks


def jacobians(
    function: Callable[[F64], F64],
    inputs: F64,
    input_cov: F64,
    width: int,
    *,
    rel_step: float = 1e-3,
    shared: Shared | None = None,
) -> tuple[F64, F64 | None]:
    """Any batched ``function``'s derivatives, as :func:`propagate` takes an estimate's.

    ``function`` maps stacked (perturbed) inputs to (R T, ``width``) outputs (what
    :func:`propagate` calls with three); returns (T, W, N, 9) per view and, with
    ``shared``, (T, W, G, S) per shared group (None without). The misclosure's residuals
    (:mod:`twopose.uncertainty.misclosure`) go through it.
    """
    x = np.asarray(inputs, dtype=np.float64)
    C = np.asarray(input_cov, dtype=np.float64)
    T = x.shape[0]
    Cs = np.zeros((T, 0, 0, 0)) if shared is None else np.asarray(shared.cov, dtype=np.float64)
    J, Js, _, _ = _jacobians(function, x, C, shared, Cs, rel_step, width)
    return J, None if shared is None else Js


def propagate(
    estimate: Callable[[F64], F64],
    inputs: F64,
    input_cov: F64,
    *,
    rel_step: float = 1e-3,
    shared: Shared | None = None,
    second_order: bool = False,
) -> Propagated:
    """Propagate per-view input covariances (and shared ones) through a batched estimator.

    Parameters
    ----------
    estimate : callable
        ``(R T, N, 9) inputs -> (R T, 3)`` estimates, rows independent (NaN where it
        fails): it is called with R perturbed copies of the T trials stacked along the
        first axis (row ``r T + t`` is trial ``t``), so per-trial context must be tiled.
        With ``shared``, each view's inputs are followed by its shared values:
        ``(R T, N, 9 + S)``.
    inputs : (T, N, 9) ndarray
        Per-view inputs in the :data:`INPUTS_PER_VIEW` layout (NaN in unused entries).
    input_cov : (T, N, 9, 9) ndarray
        Covariance of each view's inputs; views are independent.
    rel_step : float
        Central-difference step as a fraction of each input's standard deviation, so the
        step is right whatever the units.
    shared : Shared, optional
        Inputs common to a group of views (a camera's intrinsics), independent of the
        per-view ones: ``Sigma_x += sum_g J_g Sigma_g J_g^T``, with ``J_g`` the derivative
        with respect to the group's value in all of its views at once.
    second_order : bool
        Each input also stepped by ``h = sqrt(3)`` sigma and ``Sigma_x += sum_k c_k
        c_k^T``, ``c_k = sqrt(h^2 - 1) / (2 h^2) (f(x + h_k) + f(x - h_k) - 2 f(x))``: for a
        normal input ``1/2 H_kk^2 sigma_k^4``, the variance the estimate's curvature in
        each input adds (Norgaard, Poulsen and Ravn's DD2 term; the mixed second
        derivatives are not seen, as by the unscented transform's points on the axes).
        ``J`` stays the derivative, so the region is never narrower than first order's
        (the secant of a wide step would be, where the estimate saturates). A row whose
        wide steps leave the estimator's domain (NaN) has no second-order term there.

    Returns
    -------
    Propagated
        Rows whose estimate fails near the inputs come back NaN.
    """
    x = np.asarray(inputs, dtype=np.float64)
    C = np.asarray(input_cov, dtype=np.float64)
    T, N, _ = x.shape
    Cs = np.zeros((T, 0, 0, 0)) if shared is None else np.asarray(shared.cov, dtype=np.float64)
    J, Js, K, Ks = _jacobians(estimate, x, C, shared, Cs, rel_step, second_order=second_order)
    # Views are independent: Sigma = sum_n J_n C_n J_n^T.
    JC = np.einsum("tinj,tnjk->tink", J, C)
    cov = np.einsum("tink,tlnk->til", JC, J)
    curvature = shared_curvature = None
    if second_order:  # each input's second-order part, sum_k c_k c_k^T
        curvature, shared_curvature = CURVATURE_WEIGHT * K, CURVATURE_WEIGHT * Ks
        cov = cov + np.einsum("tink,tjnk->tij", curvature, curvature)
    group_var = np.zeros((T, N, len(_GROUPS)))
    for g, (_, sl) in enumerate(_GROUPS):  # each input group's share, for dominant_input
        Jg, Cg = J[:, :, :, sl], C[:, :, sl, sl]
        group_var[:, :, g] = np.einsum("tinj,tnjk,tink->tn", Jg, Cg, Jg)
    if shared is None:
        return Propagated(cov_grid=cov, jacobian=J, variance_by_group=group_var,
                          curvature=curvature)  # fmt: skip
    # Groups (cameras) are independent of each other and of the per-view inputs.
    cov_shared = np.einsum("tigs,tgsr,tjgr->tij", Js, Cs, Js)
    if shared_curvature is not None:
        cov_shared = cov_shared + np.einsum("tigs,tjgs->tij", shared_curvature, shared_curvature)
    return Propagated(
        cov_grid=cov + cov_shared,
        jacobian=J,
        variance_by_group=group_var,
        shared_jacobian=Js,
        shared_variance=np.trace(cov_shared, axis1=1, axis2=2),
        curvature=curvature,
    )


#: A Jacobian column: (view, input, None) for a view's own input, or (group, input, the
#: (T, N) views of that group) for a shared one, perturbed in all of its views at once.
_Column = tuple[int, int, NDArray[np.bool_] | None]


def _difference_columns(
    estimate: Callable[[F64], F64],
    x: F64,
    steps: list[F64],
    columns: list[_Column],
    centre: F64 | None = None,
) -> list[tuple[F64, F64]]:
    """Central differences of ``columns`` of the Jacobian, in one call.

    Each column's derivative (T, W) and, with the estimate at ``x`` (``centre`` (T, W)),
    its curvature ``f(x + h) + f(x - h) - 2 f(x)`` (else zero); ``steps`` (T,) per column
    (0: an exact input, its column 0).
    """
    T = x.shape[0]
    K = len(columns)
    h = np.stack(steps)  # (K, T)
    step = np.where(h > 0, h, 0.0)
    batch = np.repeat(x[None], 2 * K, axis=0)  # (2K, T, N, D): +step copies, then -step
    for k, (n, d, views) in enumerate(columns):
        if views is None:
            batch[k, :, n, d] += step[k]
            batch[K + k, :, n, d] -= step[k]
        else:  # every view of the group at once
            batch[k, ..., d] += np.where(views, step[k][:, None], 0.0)
            batch[K + k, ..., d] -= np.where(views, step[k][:, None], 0.0)
    with np.errstate(invalid="ignore", divide="ignore"):
        est = estimate(batch.reshape(2 * K * T, *x.shape[1:])).reshape(2, K, T, -1)
        col = (est[0] - est[1]) / (2.0 * step[..., None])  # (K, T, W)
        curve = np.zeros_like(col) if centre is None else est[0] + est[1] - 2.0 * centre[None]
    used = (h > 0)[..., None]
    return [(np.where(used[k], col[k], 0.0), np.where(used[k], curve[k], 0.0)) for k in range(K)]


#: What :func:`dominant_input` names: ``variance_by_group``'s last axis in its order, then
#: the shared inputs (the cameras' intrinsics).
INPUT_GROUPS = (
    "pixels",
    "x translation",
    "y translation",
    "z translation",
    "rotation",
    "intrinsics",
)


def dominant_input(
    variance_by_group: F64, shared_variance: F64 | None = None
) -> tuple[list[str], F64]:
    """Per trial, the kind of input with the largest share of the variance.

    Inputs are summed over poses; the share is of the variance, e.g. ``"x translation", 0.97``;
    with ``shared_variance`` (T,), the intrinsics compete too.
    """
    flat = variance_by_group.sum(axis=1)  # (T, 5)
    if shared_variance is not None:
        flat = np.concatenate([flat, np.asarray(shared_variance)[:, None]], axis=1)
    T = flat.shape[0]
    total = flat.sum(axis=1)
    names = INPUT_GROUPS
    best = np.argmax(np.nan_to_num(flat, nan=-1.0), axis=1)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = flat[np.arange(T), best] / total
    ok = np.isfinite(share) & (total > 0)
    return [names[b] if o else "" for b, o in zip(best, ok, strict=True)], np.where(
        ok, share, np.nan
    )


#: 95% quantiles of chi-square with 1, 2 and 3 degrees of freedom.
CHI2_95 = {1: 3.841458820694124, 2: 5.991464547107979, 3: CHI2_3DOF_95}
#: Covariance directions under this fraction of the largest variance are exact (a ground
#: point's height is the ground's), so the error is normalized over the others only.
_RANK_TOLERANCE = 1e-9


def _kept(w: F64) -> NDArray[np.bool_]:
    """(T, 3) which of the eigenvalues ``w`` (ascending) are the region's directions."""
    return np.asarray(w > _RANK_TOLERANCE * w[:, -1:])


def region_dof(cov: F64) -> NDArray[np.int_]:
    """(T,) each 95% region's degrees of freedom: its covariance's non-degenerate directions.

    3 for a point, 2 for a ground point (its height is the ground's) or a line's point (it
    moves across the line only); 0 where the covariance is not finite.
    """
    S = np.asarray(cov, dtype=np.float64)
    dof = np.zeros(S.shape[0], dtype=np.int_)
    good = np.isfinite(S).all(axis=(1, 2))
    if good.any():
        dof[good] = _kept(np.asarray(np.linalg.eigvalsh(S[good]), dtype=np.float64)).sum(axis=1)
    return dof


def chi2_95(dof: NDArray[np.int_]) -> F64:
    """(T,) the 95% quantile of chi-square on each region's ``dof`` (NaN for 0)."""
    return np.array([CHI2_95.get(int(d), np.nan) for d in np.atleast_1d(dof)], dtype=np.float64)


def semiaxis95(cov: F64) -> F64:
    """(T,) the 95% region's longest semi-axis, ``sqrt(CHI2_95[dof] * largest eigenvalue)``.

    Judged by the region's own degrees of freedom (:func:`region_dof`): a rank-2 region (a
    ground point, a line's point) by chi-square's 2-dof quantile, not the 3-dof one. The
    one rule for a 95% region's size; NaN where the covariance is not finite.
    """
    S = np.asarray(cov, dtype=np.float64)
    out = np.full(S.shape[0], np.nan)
    good = np.isfinite(S).all(axis=(1, 2))
    if good.any():
        largest = np.clip(np.linalg.eigvalsh(S[good])[:, -1], 0.0, None)
        with np.errstate(invalid="ignore"):  # an exact estimate (no noise): a point, 0
            out[good] = np.where(largest > 0, np.sqrt(chi2_95(region_dof(S[good])) * largest), 0.0)
    return out


def nees(error: F64, cov: F64) -> tuple[F64, NDArray[np.int_]]:
    """Normalized estimation error squared ``e^T Sigma^+ e`` and its degrees of freedom.

    Over the covariance's non-degenerate directions: a ground point (``y = h`` exactly)
    has two. Rows with a non-finite error or covariance are NaN with 0 degrees of freedom.
    """
    e = np.asarray(error, dtype=np.float64)
    S = np.asarray(cov, dtype=np.float64)
    out = np.full(e.shape[0], np.nan)
    dof = np.zeros(e.shape[0], dtype=np.int_)
    good = np.isfinite(e).all(axis=1) & np.isfinite(S).all(axis=(1, 2))
    if good.any():
        w, V = np.linalg.eigh(S[good])
        keep = _kept(w)
        z = np.einsum("tji,tj->ti", V, e[good])  # error in the eigenbasis
        with np.errstate(divide="ignore", invalid="ignore"):
            out[good] = np.where(keep, z**2 / w, 0.0).sum(axis=1)
        dof[good] = keep.sum(axis=1)
    out[dof == 0] = np.nan
    return out, dof


#: The columns :func:`uncertainty_columns` fills, in order: 1-sigma per axis, the
#: covariances, 95% half-widths per axis, the 95% region's longest semi-axis (by its own
#: degrees of freedom, :func:`semiaxis95`), the
#: normalized error ``nees`` over its ``nees_dof`` non-degenerate directions (a ground
#: point has 2, its height being exact) and whether the truth is inside the 95% ellipsoid.
SPREAD_COLUMNS = (
    "sigma_x",
    "sigma_y",
    "sigma_z",
    "cov_xy",
    "cov_xz",
    "cov_yz",
    "ci95_x",
    "ci95_y",
    "ci95_z",
    "semiaxis95",
    "nees",
    "nees_dof",
    "within95",
)


def uncertainty_columns(error: F64, cov: F64) -> dict[str, F64]:
    """The :data:`SPREAD_COLUMNS` from errors (T, 3) and covariances (T, 3, 3)."""
    sigma = np.sqrt(np.diagonal(cov, axis1=1, axis2=2))
    with np.errstate(invalid="ignore"):
        score, dof = nees(error, cov)
        limit = chi2_95(dof)
        within = np.where(np.isfinite(score), score <= limit, np.nan)
    half95 = NormalDist().inv_cdf(0.975)
    values = (
        *(sigma[:, i] for i in range(3)),
        cov[:, 0, 1],
        cov[:, 0, 2],
        cov[:, 1, 2],
        *(half95 * sigma[:, i] for i in range(3)),
        semiaxis95(cov),
        score,
        dof,
        within,
    )
    return dict(zip(SPREAD_COLUMNS, values, strict=True))


def region_widening(cov: F64, model: F64) -> F64:
    """(T,) each region's largest variance in ``cov`` against ``model``'s (NaN: not finite).

    1 exactly where the two are the same.
    """
    out = np.full(len(cov), np.nan)
    finite = np.isfinite(cov).all(axis=(1, 2)) & np.isfinite(model).all(axis=(1, 2))
    if finite.any():
        new, old = np.linalg.eigvalsh(cov[finite])[:, -1], np.linalg.eigvalsh(model[finite])[:, -1]
        with np.errstate(invalid="ignore", divide="ignore"):
            out[finite] = np.where(new == old, 1.0, new / old)
    return out
