"""The reprojection-optimal N-view line: maximum likelihood over the measured segments.

Each view measures a segment (two endpoints). Under Gaussian noise on the endpoints across
the image line, the maximum-likelihood 3-D line minimises the sum of the squared distances
of every measured endpoint to the reprojected line (Bartoli and Sturm, "Structure-from-motion
using lines: representation, triangulation and bundle adjustment", CVIU 100, 2005). The line
is kept in their orthonormal representation, Plücker ``(m, d) ~ U diag(cos phi, sin phi)``
with ``U`` in SO(3): four parameters, updated as ``U <- U exp([theta]x), phi <- phi + theta_4``,
refined by Levenberg-Marquardt from the algebraic (rank-2) line of
:func:`twopose.solve.nview.triangulate_lines`. Its covariance is ``s^2 (J^T J)^-1`` at the optimum,
carried to the reported point and direction.

Batched over trials, no I/O. Lines are expressed, while refined, in a frame centred at the
views' mean camera centre and scaled by the line's distance from it, where the
representation is well conditioned (it is singular for a line through the origin).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from twopose.arrays import F64, Bools
from twopose.camera.model import camera_centres
from twopose.errors import InputValueError
from twopose.solve.nview import (
    DEFAULT_MIN_CONDITIONING,
    NViewLines,
    segment_lines,
    triangulate_lines,
)

__all__ = ["OptimalLines", "centroid_segments", "endpoint_distances", "optimal_lines"]

Status = NDArray[np.str_]

#: Virtual half-lengths (px) of a segment standing for a centroid and an angle are kept in
#: this range (an angle known exactly would give an infinite one).
HALF_LENGTH_PX = (1.0, 1e4)


@dataclass(frozen=True, kw_only=True)
class OptimalLines:
    """Batched reprojection-optimal lines (see :func:`optimal_lines`)."""

    point_grid: F64  # (T, 3) the point closest to the last view's camera centre
    direction_grid: F64  # (T, 3) unit
    cov: F64  # (T, 6, 6) of (point_grid, direction_grid); rank 4
    rms_px: F64  # (T,) RMS distance of the measured endpoints to the reprojected line
    start_rms_px: F64  # (T,) the same for the algebraic line (triangulate_lines)
    variance_factor: F64  # (T,) weighted sum of squares / (2 views - 4); NaN with 2 views
    iterations: NDArray[np.int64]  # (T,) Levenberg-Marquardt iterations used
    conditioning: F64  # (T,) largest plane-angle sine over view pairs
    status: Status
    reason: Status


def centroid_segments(
    px: ArrayLike,
    theta_deg: ArrayLike,
    sigma_across_px: ArrayLike,
    sigma_theta_deg: ArrayLike,
    max_half_length_px: ArrayLike = HALF_LENGTH_PX[1],
) -> tuple[F64, F64]:
    """Segments equivalent to a centroid and an angle with their 1-sigma.

    Segments (..., 4) and their endpoints' 1-sigma (...) equivalent to a centroid and an
    angle measured with the given 1-sigma errors.

    Two endpoints ``h`` either side of the centroid, each with noise ``sqrt(2) sigma_across``
    across the line, give their midpoint the offset noise ``sigma_across`` and the line the
    angle noise ``sigma_across / h``: ``h = sigma_across / sigma_theta`` (radians), kept
    within :data:`HALF_LENGTH_PX` and under ``max_half_length_px`` (a detected segment
    within the image: an angle whose spread is far below what its segment's length allows
    is not trusted beyond that).
    """
    p = np.asarray(px, dtype=np.float64)
    t = np.deg2rad(np.asarray(theta_deg, dtype=np.float64))
    s_across = np.asarray(sigma_across_px, dtype=np.float64)
    s_theta = np.deg2rad(np.asarray(sigma_theta_deg, dtype=np.float64))
    with np.errstate(divide="ignore", invalid="ignore"):
        h = np.where(s_theta > 0, s_across / s_theta, HALF_LENGTH_PX[1])
    h = np.clip(np.nan_to_num(h, nan=HALF_LENGTH_PX[1]), *HALF_LENGTH_PX)
    h = np.maximum(np.minimum(h, np.asarray(max_half_length_px, np.float64)), HALF_LENGTH_PX[0])
    step = h[..., None] * np.stack([np.cos(t), np.sin(t)], axis=-1)
    return np.concatenate([p - step, p + step], axis=-1), np.sqrt(2.0) * s_across


def endpoint_distances(
    point_grid: ArrayLike, direction_grid: ArrayLike, segments_px: ArrayLike, P: ArrayLike
) -> F64:
    """(T, N, 2) distances (px) of each view's measured endpoints to the line reprojected.

    ``point_grid``, ``direction_grid`` (T, 3); ``segments_px`` (T, N, 4); ``P`` (T, N, 3, 4).
    """
    x = np.asarray(point_grid, dtype=np.float64)
    u = np.asarray(direction_grid, dtype=np.float64)
    p = np.asarray(P, dtype=np.float64)
    a = np.einsum("tnij,tj->tni", p, np.concatenate([x, np.ones((len(x), 1))], axis=1))
    b = np.einsum("tnij,tj->tni", p[..., :3], u)
    return np.abs(_signed_distances(np.cross(a, b), np.asarray(segments_px, dtype=np.float64)))


def _signed_distances(lines: F64, segments: F64) -> F64:
    """(..., 2) signed distances of the segments' endpoints (..., 4) to image lines (..., 3)."""
    ends = np.stack([segments[..., :2], segments[..., 2:]], axis=-2)  # (..., 2, 2)
    with np.errstate(divide="ignore", invalid="ignore"):
        norm = np.hypot(lines[..., 0], lines[..., 1])
        return np.asarray(
            (np.einsum("...ki,...i->...k", ends, lines[..., :2]) + lines[..., 2:3])
            / norm[..., None]
        )


def _checked_inputs(
    segments_px: ArrayLike, P: ArrayLike, valid: ArrayLike | None, sigma_px: ArrayLike | None
) -> tuple[F64, F64, Bools, F64]:
    """The segments (unused views zeroed), cameras, the views used and each view's weight.

    A view is used when its segment is finite (and ``valid`` says so); its weight is
    ``1 / sigma_px`` (1 without sigmas, 0 unused).
    """
    seg = np.asarray(segments_px, dtype=np.float64)
    p = np.asarray(P, dtype=np.float64)
    if seg.ndim != 3 or seg.shape[2] != 4 or p.shape != (*seg.shape[:2], 3, 4):
        raise InputValueError(
            f"segments must be (T, N, 4) and P (T, N, 3, 4); got {seg.shape}, {p.shape}"
        )
    ok = np.asarray(np.isfinite(seg).all(axis=2))
    if valid is not None:
        ok &= np.asarray(valid, dtype=bool)
    if sigma_px is None:
        weight = np.ones(seg.shape[:2])
    else:
        sigma = np.broadcast_to(np.asarray(sigma_px, dtype=np.float64), seg.shape[:2])
        if not (np.isfinite(sigma[ok]).all() and (sigma[ok] > 0).all()):
            raise InputValueError("sigma_px must be finite and > 0 for every view used")
        weight = np.where(ok, 1.0 / np.where(ok, sigma, 1.0), 0.0)
    weight = np.where(ok, weight, 0.0)
    return np.where(ok[..., None], seg, 0.0), p, ok, weight


def optimal_lines(
    segments_px: ArrayLike,
    P: ArrayLike,
    *,
    valid: ArrayLike | None = None,
    sigma_px: ArrayLike | None = None,
    iterations: int = 100,
    min_conditioning: float = DEFAULT_MIN_CONDITIONING,
) -> OptimalLines:
    """Lines from N >= 2 measured segments, maximum likelihood over their endpoints.

    Starts from today's algebraic lines, :func:`twopose.solve.nview.triangulate_lines` (its
    statuses and conditioning are the result's): of the rank-2 line, the weighted line and
    each pair of views' line, the one nearest the measurements. Then minimises
    ``sum (d_ij / sigma_i)^2`` over views ``i`` and endpoints ``j``, ``d`` the distance of
    the measured endpoint to the reprojected line, by Levenberg-Marquardt (Nielsen's
    damping) in the orthonormal representation (four parameters). With two views the line
    meets both image lines exactly: the residual is zero and the line is the algebraic one.
    With equal ``sigma_px`` (or none) ``rms_px`` is never above ``start_rms_px``.

    Parameters
    ----------
    segments_px : (T, N, 4) array_like
        ``(x0, y0, x1, y1)`` per view (:func:`centroid_segments` makes them from a centroid
        and an angle); rows of invalid views are ignored.
    P : (T, N, 3, 4) array_like
    valid : (T, N) bool array_like, optional
        Which views a trial uses (default: those with finite segments).
    sigma_px : (T, N) array_like, optional
        Per view, the 1-sigma error of an endpoint across the line. Given: the views are
        weighted by it and ``cov`` is ``(J^T J)^-1`` (the a-priori noise). Omitted: equal
        weights and ``cov`` scaled by the a-posteriori ``variance_factor`` (NaN with two
        views, which leave no redundancy to estimate it from).
    """
    seg, p, ok, weight = _checked_inputs(segments_px, P, valid, sigma_px)
    T = seg.shape[0]
    start = triangulate_lines(segment_lines(seg), p, valid=ok, min_conditioning=min_conditioning)
    out_point = np.full((T, 3), np.nan)
    out_dir = np.full((T, 3), np.nan)
    cov = np.full((T, 6, 6), np.nan)
    rms = np.full(T, np.nan)
    start_rms = np.full(T, np.nan)
    factor = np.full(T, np.nan)
    used = np.zeros(T, dtype=np.int64)
    rows = np.flatnonzero(start.status == "ok")
    if rows.size:
        x0, u0 = _best_start(start, seg[rows], p[rows], ok[rows], weight[rows], rows)
        fit = _refine(x0, u0, seg[rows], p[rows], ok[rows], weight[rows], iterations)
        n_res = 2 * ok[rows].sum(axis=1)
        dof = n_res - 4
        with np.errstate(invalid="ignore", divide="ignore"):
            factor[rows] = np.where(dof > 0, fit.cost / np.maximum(dof, 1), np.nan)
        scale = factor[rows] if sigma_px is None else np.ones(rows.size)
        out_point[rows], out_dir[rows] = fit.point, fit.direction
        cov[rows] = scale[:, None, None] * fit.cov
        rms[rows] = np.sqrt(fit.sq_px / n_res)
        with np.errstate(invalid="ignore"):
            d0 = endpoint_distances(
                start.point_grid[rows], start.direction_grid[rows], seg[rows], p[rows]
            )
        start_sq = (np.where(ok[rows][..., None], d0, 0.0) ** 2).sum(axis=(1, 2))
        start_rms[rows] = np.sqrt(start_sq / n_res)
        used[rows] = fit.iterations
    return OptimalLines(
        point_grid=out_point,
        direction_grid=out_dir,
        cov=cov,
        rms_px=rms,
        start_rms_px=start_rms,
        variance_factor=factor,
        iterations=used,
        conditioning=start.conditioning,
        status=start.status,
        reason=start.reason,
    )


#: Up to this many views, every pair's two-plane line is also a candidate start.
MAX_VIEWS_FOR_PAIRS = 8


def _best_start(
    start: NViewLines,
    seg: F64,
    P: F64,
    ok: NDArray[np.bool_],
    weight: F64,
    rows: NDArray[np.intp],
) -> tuple[F64, F64]:
    """The start of least cost among the candidate lines.

    The candidates: the algebraic line, the weighted one and (up to :data:`MAX_VIEWS_FOR_PAIRS`
    views) each pair of views' line. An algebraic line can sit in another basin than the optimum
    when the planes meet at a small angle.
    """
    lines = segment_lines(seg)
    candidates = [(start.point_grid[rows], start.direction_grid[rows])]
    sigma = np.where(ok, 1.0 / np.where(weight > 0, weight, 1.0), 1.0)
    weighted = triangulate_lines(lines, P, valid=ok, estimator="weighted", sigma_px=sigma)
    candidates.append((weighted.point_grid, weighted.direction_grid))
    N = ok.shape[1]
    if N <= MAX_VIEWS_FOR_PAIRS:
        for i in range(N):
            for j in range(i + 1, N):
                pair = np.zeros_like(ok)
                pair[:, [i, j]] = ok[:, [i, j]]
                two = triangulate_lines(lines, P, valid=pair)
                candidates.append((two.point_grid, two.direction_grid))
    relative = weight / weight.max(axis=1, keepdims=True)  # no overflow for a tiny sigma
    best_x, best_u = candidates[0][0].copy(), candidates[0][1].copy()
    best = np.full(len(rows), np.inf)
    for x, u in candidates:
        with np.errstate(invalid="ignore"):
            r = endpoint_distances(x, u, seg, P) * relative[..., None]
            cost = np.where(ok[..., None], r, 0.0) ** 2
        total = cost.sum(axis=(1, 2))
        take = np.isfinite(total) & (total < best)
        best[take], best_x[take], best_u[take] = total[take], x[take], u[take]
    return best_x, best_u


@dataclass(frozen=True, kw_only=True)
class _Fit:
    point: F64
    direction: F64
    cov: F64  # unscaled (J^T J)^-1 carried to (point, direction)
    cost: F64  # weighted sum of squares
    sq_px: F64  # unweighted sum of squared distances (px^2)
    iterations: NDArray[np.int64]


def _skew(v: F64) -> F64:
    out = np.zeros((*v.shape[:-1], 3, 3))
    out[..., 0, 1], out[..., 0, 2] = -v[..., 2], v[..., 1]
    out[..., 1, 0], out[..., 1, 2] = v[..., 2], -v[..., 0]
    out[..., 2, 0], out[..., 2, 1] = -v[..., 1], v[..., 0]
    return out


def _rodrigues(w: F64) -> F64:
    """(T, 3, 3) rotations ``exp([w]x)``."""
    angle = np.linalg.norm(w, axis=-1)
    K = _skew(w)
    with np.errstate(invalid="ignore", divide="ignore"):
        a = np.where(angle > 1e-8, np.sin(angle) / angle, 1.0 - angle**2 / 6)
        b = np.where(angle > 1e-8, (1.0 - np.cos(angle)) / angle**2, 0.5 - angle**2 / 24)
    return np.asarray(np.eye(3) + a[:, None, None] * K + b[:, None, None] * (K @ K))


class _Problem:
    """The residuals of one batch in its normalised frames.

    Line projection matrices ``l = A d + B m`` per view (``P' = P H`` with ``H`` the frame's
    scale and origin).
    """

    def __init__(
        self, seg: F64, P: F64, ok: NDArray[np.bool_], weight: F64, origin: F64, scale: F64
    ):
        H = np.zeros((len(origin), 4, 4))
        H[:, :3, :3] = scale[:, None, None] * np.eye(3)
        H[:, :3, 3], H[:, 3, 3] = origin, 1.0
        Pn = np.einsum("tnij,tjk->tnik", P, H)
        Pn = Pn / np.linalg.norm(Pn, axis=(2, 3), keepdims=True)
        M, p4 = Pn[..., :3], Pn[..., 3]
        self.A = np.einsum("tnij,tnjk->tnik", _skew(p4), M)
        self.B = np.cross(M[..., [1, 2, 0], :], M[..., [2, 0, 1], :])  # rows r2xr3, r3xr1, r1xr2
        self.seg, self.ok, self.weight = seg, ok, weight

    def lines(self, m: F64, d: F64) -> F64:
        return np.asarray(
            np.einsum("tnij,tj->tni", self.A, d) + np.einsum("tnij,tj->tni", self.B, m)
        )

    def distances(self, m: F64, d: F64) -> F64:
        """(T, N, 2) signed endpoint distances (px), zero for unused views."""
        r = _signed_distances(self.lines(m, d), self.seg)
        return np.where(self.ok[..., None], r, 0.0)

    def residuals(self, m: F64, d: F64) -> F64:
        """(T, 2N) weighted residuals."""
        r = self.distances(m, d) * self.weight[..., None]
        return r.reshape(len(r), -1)

    def jacobian(self, U: F64, w: F64, rows: NDArray[np.intp] | slice = slice(None)) -> F64:
        """The Jacobian (R, 2N, 4) of the weighted residuals of ``rows``.

        (R, 2N, 4) of the weighted residuals of ``rows`` (lines ``U``, ``w`` of those rows)
        in the orthonormal update (theta, dphi).
        """
        u1, u2, u3 = U[..., 0], U[..., 1], U[..., 2]
        w1, w2 = w[:, :1], w[:, 1:]
        zero = np.zeros_like(u1)
        dm = np.stack([zero, -w1 * u3, w1 * u2, -w2 * u1], axis=-1)  # (T, 3, 4)
        dd = np.stack([w2 * u3, zero, -w2 * u1, w1 * u2], axis=-1)
        m, d = w1 * u1, w2 * u2
        A, B, seg = self.A[rows], self.B[rows], self.seg[rows]
        lines = np.einsum("tnij,tj->tni", A, d) + np.einsum("tnij,tj->tni", B, m)  # (R, N, 3)
        dl = np.einsum("tnij,tjk->tnik", A, dd) + np.einsum("tnij,tjk->tnik", B, dm)
        ends = np.stack([seg[..., :2], seg[..., 2:]], axis=-2)  # (R, N, 2, 2)
        ends_h = np.concatenate([ends, np.ones((*ends.shape[:-1], 1))], axis=-1)
        n = np.hypot(lines[..., 0], lines[..., 1])[..., None, None]  # (T, N, 1, 1)
        dot = np.einsum("tnki,tni->tnk", ends_h, lines)[..., None]  # (T, N, 2, 1)
        l12 = np.concatenate([lines[..., :2], np.zeros((*lines.shape[:-1], 1))], axis=-1)
        with np.errstate(invalid="ignore", divide="ignore"):
            grad = ends_h / n - dot * l12[:, :, None, :] / n**3  # dr/dl (T, N, 2, 3)
        J = np.einsum("tnki,tnij->tnkj", grad, dl)
        J = np.where(self.ok[rows][..., None, None], J, 0.0) * self.weight[rows][..., None, None]
        return np.asarray(J.reshape(len(J), -1, 4))


def _orthonormal(point: F64, direction: F64) -> tuple[F64, F64]:
    """(U, w) of lines through ``point`` (not the origin) with unit ``direction``."""
    m = np.cross(point, direction)
    u1 = m / np.linalg.norm(m, axis=1, keepdims=True)
    U = np.stack([u1, direction, np.cross(u1, direction)], axis=-1)
    w = np.stack([np.linalg.norm(m, axis=1), np.ones(len(m))], axis=1)
    return U, w / np.linalg.norm(w, axis=1, keepdims=True)


def _plucker(U: F64, w: F64) -> tuple[F64, F64]:
    return w[:, :1] * U[..., 0], w[:, 1:] * U[..., 1]


def _update(U: F64, w: F64, step: F64) -> tuple[F64, F64]:
    phi = np.arctan2(w[:, 1], w[:, 0]) + step[:, 3]
    return U @ _rodrigues(step[:, :3]), np.stack([np.cos(phi), np.sin(phi)], axis=1)


def _reported(U: F64, w: F64, origin: F64, scale: F64, near: F64) -> tuple[F64, F64]:
    """Grid point nearest ``near`` and the unit direction, with no sign flip."""
    m, d = _plucker(U, w)
    u = d / np.linalg.norm(d, axis=1, keepdims=True)
    x = origin + scale[:, None] * np.cross(d, m) / np.einsum("ti,ti->t", d, d)[:, None]
    return x + np.einsum("ti,ti->t", near - x, u)[:, None] * u, u


#: A weighted sum of squares this small is an exact fit (nothing left to refine).
EXACT = 1e-20


def _distance(point: F64, direction: F64, origin: F64) -> F64:
    """(T,) distance of ``origin`` from the lines through ``point`` along unit ``direction``."""
    offset = point - origin
    across = offset - np.einsum("ti,ti->t", offset, direction)[:, None] * direction
    return np.asarray(np.linalg.norm(across, axis=1))


def _refine(
    point: F64,
    direction: F64,
    seg: F64,
    P: F64,
    ok: NDArray[np.bool_],
    weight: F64,
    iterations: int,
) -> _Fit:
    T, N = ok.shape
    centres = camera_centres(P)
    origin, scale = _working_frame(point, direction, centres, ok)
    last = centres[np.arange(T), (ok * np.arange(N)).argmax(axis=1)]
    # Weights relative to each row's largest: the same minimum, no overflow for a tiny sigma.
    top = weight.max(axis=1)
    problem = _Problem(seg, P, ok, weight / top[:, None], origin, scale)
    U, w = _orthonormal((point - origin) / scale[:, None], direction)
    U, w, cost, used = _levenberg_marquardt(problem, U, w, iterations)
    x, u, cov6 = _reported_covariance(problem, U, w, origin, scale, last)
    sq = (problem.distances(*_plucker(U, w)) ** 2).sum(axis=(1, 2))
    with np.errstate(over="ignore", under="ignore", invalid="ignore"):  # absurd sigma: inf
        return _Fit(
            point=x,
            direction=u,
            cov=cov6 * (1 / top[:, None, None]) ** 2,
            cost=cost * top**2,
            sq_px=sq,
            iterations=used,
        )


def _working_frame(
    point: F64, direction: F64, centres: F64, ok: NDArray[np.bool_]
) -> tuple[F64, F64]:
    """The refinement's origin (T, 3) and unit of length (T,).

    The origin at the cameras' centroid, moved off the line if the line passes by it; the
    unit of length the line's distance from it.
    """
    origin = np.where(ok[..., None], centres, 0.0).sum(1) / ok.sum(1)[:, None]
    spread = np.linalg.norm(np.where(ok[..., None], centres - point[:, None], 0.0), axis=2).max(1)
    close = _distance(point, direction, origin) < 0.1 * spread
    if close.any():
        side = np.cross(direction[close], np.eye(3)[np.abs(direction[close]).argmin(axis=1)])
        side /= np.linalg.norm(side, axis=1, keepdims=True)
        origin[close] = point[close] - spread[close, None] * side
    return origin, _distance(point, direction, origin)


def _levenberg_marquardt(
    problem: _Problem, U: F64, w: F64, iterations: int
) -> tuple[F64, F64, F64, NDArray[np.int64]]:
    """Refine every trial's (U, w) at once; returns them, the cost and the iterations used."""
    T = U.shape[0]
    r = problem.residuals(*_plucker(U, w))
    cost = (r**2).sum(axis=1)
    lam = np.full(T, 1e-3)
    nu = np.full(T, 2.0)
    active = cost > EXACT  # two views: the start already meets both image lines
    used = np.zeros(T, dtype=np.int64)
    for _ in range(iterations):
        if not active.any():
            break
        a = np.flatnonzero(active)
        # The damped step from the SVD of the column-scaled Jacobian, not the normal
        # equations: a view that sees the line nearly end-on makes J^T J ill-conditioned.
        J = problem.jacobian(U[a], w[a], a)
        finite = np.isfinite(J).all(axis=(1, 2))
        if not finite.all():  # a line through a camera centre: nothing left to refine
            active[a[~finite]] = False
            a, J = a[finite], J[finite]
            if not a.size:
                break
        norm = np.maximum(np.linalg.norm(J, axis=1), 1e-300)  # Marquardt's scaling
        left, sv, vt = np.linalg.svd(J / norm[:, None, :], full_matrices=False)
        g = np.einsum("tki,tk->ti", left, r[a])  # U^T r
        scaled = -np.einsum("tji,tj->ti", vt, sv * g / (sv**2 + lam[a, None]))
        step = scaled / norm
        U_new, w_new = U.copy(), w.copy()
        U_new[a], w_new[a] = _update(U[a], w[a], step)
        r_new = problem.residuals(*_plucker(U_new, w_new))
        cost_new = (r_new**2).sum(axis=1)
        better = np.zeros(T, dtype=bool)
        better[a] = np.isfinite(cost_new[a]) & (cost_new[a] <= cost[a])
        gain = np.where(better, cost - cost_new, 0.0)
        U[better], w[better], r[better] = U_new[better], w_new[better], r_new[better]
        used[a] += 1
        # Nielsen's damping update: by the gain ratio after a success, doubling after a failure.
        predicted = np.zeros(T)
        grad = np.einsum("tji,tj->ti", vt, sv * g)  # scaled J^T r
        predicted[a] = np.einsum("ti,ti->t", scaled, lam[a, None] * scaled - grad)
        with np.errstate(invalid="ignore", divide="ignore"):
            rho = np.where(better, gain / np.maximum(predicted, 1e-300), 0.0)
        shrink = np.maximum(1.0 / 3.0, 1.0 - (2.0 * np.minimum(rho, 1.0) - 1.0) ** 3)
        lam = np.where(better, np.maximum(lam * shrink, 1e-12), np.where(active, lam * nu, lam))
        nu = np.where(better, 2.0, np.where(active, nu * 2.0, nu))
        small_step = np.zeros(T, dtype=bool)
        small_step[a] = np.abs(step).max(axis=1) < 1e-12
        cost = np.where(better, cost_new, cost)
        done = (better & (gain <= 1e-14 * cost)) | small_step | (lam > 1e12) | (cost <= EXACT)
        active &= ~done
    return U, w, cost, used


def _reported_covariance(
    problem: _Problem, U: F64, w: F64, origin: F64, scale: F64, last: F64
) -> tuple[F64, F64, F64]:
    """The reported (point nearest the last camera, u) and their (T, 6, 6) covariance.

    The 4 parameters' covariance from the information J^T J, carried by central
    differences; u's sign is fixed so that its largest component is positive.
    """
    T = U.shape[0]
    J = problem.jacobian(U, w)
    info = np.einsum("tki,tkj->tij", J, J)
    cov4 = np.full((T, 4, 4), np.nan)
    invertible = np.linalg.cond(info) < 1e14
    cov4[invertible] = np.linalg.inv(info[invertible])
    x, u = _reported(U, w, origin, scale, last)
    G = np.zeros((T, 6, 4))
    h = 1e-6
    for k in range(4):
        e = np.zeros((T, 4))
        e[:, k] = h
        xp, up = _reported(*_update(U, w, e), origin, scale, last)
        xm, um = _reported(*_update(U, w, -e), origin, scale, last)
        G[:, :3, k], G[:, 3:, k] = (xp - xm) / (2 * h), (up - um) / (2 * h)
    flip = np.take_along_axis(u, np.abs(u).argmax(axis=1)[:, None], 1) < 0
    sign = np.where(flip, -1.0, 1.0)
    G[:, 3:] *= sign[:, :, None]
    return x, u * sign, np.einsum("tik,tkl,tjl->tij", G, cov4, G)
