"""Solvers: the thesis' three reconstructions, vectorized over trials, no I/O.

Inputs are batched over T trials and N >= 2 views, each view a projection matrix
``P = K [R^T | -R^T c]`` in the grid frame (:func:`projection_matrices`); results are frozen
dataclasses of arrays with a conditioning measure and a status per trial:

* ``ok``
* ``degenerate`` with the reason (point on the baseline, line coplanar with the baseline,
  line parallel to the ground, point behind a camera)
* ``no_detection`` when an input pixel or angle is not finite.

The pipeline adds ``incomplete`` for trials missing a pose. Degenerate rows are NaN by
design and say so; nothing raises for geometry, nothing is a silent inf/NaN.

Everything is expressed in the grid frame (``p_grid = R_cam_to_grid p_cam + t_grid``). With
two views the solvers give the thesis' equations (7)-(8), (14)-(15) and (19) exactly: a rigid
change of frame does not change their solutions, and the tests check them against a literal
transcription of the camera-frame forms.

The degeneracy measures (the largest parallax or plane-angle sine over pairs of views, the
no-baseline rule) live here beside the solvers that report them: each solver's status is
read from them, so a trial is triangulated and judged in one file.

Near 600 lines: the three N-view solvers, their statuses and the conditioning measures they
report are one concern (how a batch of views meets, and how well); cut apart, every solve
went back and forth between the two files.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from twopose.arrays import F64
from twopose.camera.model import camera_centres
from twopose.errors import InputValueError
from twopose.solve.margins import DEFAULT_MIN_CONDITIONING

__all__ = [
    "DEFAULT_MIN_CONDITIONING",
    "NViewLines",
    "NViewPoints",
    "camera_centres",
    "conditioning_status",
    "degrees_from_sine",
    "flag_no_baseline",
    "image_lines",
    "pairwise_max_abs_dot",
    "pairwise_max_sine",
    "parallax_sine",
    "projection_matrices",
    "segment_lines",
    "triangulate_ground",
    "triangulate_lines",
    "triangulate_points",
]

Status = NDArray[np.str_]


def _unit(v: F64) -> tuple[F64, F64]:
    norm = np.linalg.norm(v, axis=-1)
    with np.errstate(invalid="ignore", divide="ignore"):
        return v / norm[..., None], norm


def conditioning_status(
    conditioning: F64, finite: NDArray[np.bool_], min_conditioning: float, why: str
) -> tuple[Status, Status]:
    """Each row's status and reason.

    ``ok``; ``degenerate`` (``why``) below ``min_conditioning``; ``no_detection`` where a
    measurement is not ``finite``.
    """
    T = conditioning.shape[0]
    status = np.full(T, "ok", dtype="<U12")
    reason = np.full(T, "", dtype="<U64")
    bad = finite & ~(conditioning >= min_conditioning)
    status[bad], reason[bad] = "degenerate", why
    status[~finite], reason[~finite] = "no_detection", "missing or non-finite measurement"
    return status, reason


def _view_status(
    conditioning: F64, ok: NDArray[np.bool_], min_conditioning: float, why: str
) -> tuple[Status, Status]:
    """:func:`conditioning_status` for rows of N views (fewer than two usable: none)."""
    enough = np.asarray(ok.sum(axis=1) >= 2)
    status, reason = conditioning_status(
        np.where(enough, conditioning, np.nan), enough, min_conditioning, why
    )
    status[~enough], reason[~enough] = "no_detection", "fewer than two views"
    return status, reason


# How well-posed a trial is: the degeneracy measures every solver reports, batched over
# trials (rows) and views with no Python loop over views or pairs of views.


def pairwise_max_sine(u: F64, valid: NDArray[np.bool_]) -> F64:
    """Largest sine of the angle between two valid unit vectors of each row (T, N, 3).

    One Gram matrix per row (``sin^2 = 1 - cos^2`` for unit vectors), in blocks of rows so
    that memory stays near 8 MB whatever N: no Python loop over the N^2 pairs.
    """
    T, N = u.shape[:2]
    best = np.zeros(T)
    with np.errstate(invalid="ignore", divide="ignore"):
        unit = u / np.linalg.norm(u, axis=-1, keepdims=True)
    clean = np.where(valid[..., None], np.nan_to_num(unit), 0.0)
    rows = max(1, 1_000_000 // max(N * N, 1))
    for start in range(0, T, rows):
        block = slice(start, start + rows)
        cos = np.einsum("tik,tjk->tij", clean[block], clean[block])
        pair = valid[block, :, None] & valid[block, None, :]
        sine2 = np.where(pair, 1.0 - np.minimum(cos * cos, 1.0), 0.0)
        best[block] = np.sqrt(sine2.reshape(sine2.shape[0], -1).max(axis=1, initial=0.0))
    return best


def pairwise_max_abs_dot(a: F64, b: F64, valid: NDArray[np.bool_]) -> F64:
    """Largest ``|a_i . b_j|`` over pairs of valid views of each row.

    The vectors are (T, N, 3); blocked like :func:`pairwise_max_sine`.
    """
    T, N = a.shape[:2]
    best = np.zeros(T)
    rows = max(1, 1_000_000 // max(N * N, 1))
    for start in range(0, T, rows):
        block = slice(start, start + rows)
        dots = np.abs(np.einsum("tik,tjk->tij", np.nan_to_num(a[block]), np.nan_to_num(b[block])))
        pair = valid[block, :, None] & valid[block, None, :]
        masked = np.where(pair, dots, 0.0)
        best[block] = masked.reshape(masked.shape[0], -1).max(axis=1, initial=0.0)
    return best


def parallax_sine(P: ArrayLike, valid: ArrayLike, point_grid: ArrayLike) -> F64:
    """The largest sine (T,) of the angle two camera centres subtend at the point.

    (T,) the largest sine of the angle two valid camera centres subtend at each trial's
    point: the baseline as seen from the target, for every method (NaN without a point).

    For a point it is the ray parallax; for a line or a ground point it says what the plane
    angles cannot: planes through (nearly) one camera centre meet, but anywhere.
    """
    p = np.asarray(P, dtype=np.float64)
    ok = np.asarray(valid, dtype=bool)
    x = np.asarray(point_grid, dtype=np.float64)
    sine = pairwise_max_sine(camera_centres(p) - x[:, None, :], ok)
    return np.where(np.isfinite(x).all(axis=1), sine, np.nan)


def flag_no_baseline(centres: F64, ok: NDArray[np.bool_], status: Status, reason: Status) -> None:
    """Whether each trial's valid views have more than one camera centre.

    Every method, one rule: views that all share one camera centre have no baseline, so
    nothing can be triangulated from them, whatever the solver would return.
    """
    spread = np.abs(np.nan_to_num(np.where(ok[..., None], centres - centres[:, :1], 0.0)))
    scale = 1.0 + np.abs(np.nan_to_num(centres[:, :1])).max(axis=(1, 2))
    # One centre, up to the rounding of recovering it from P.
    none = (status != "no_detection") & ~(spread.max(axis=(1, 2)) > 1e-9 * scale)
    status[none] = "degenerate"
    reason[none] = "no baseline: the poses share a camera centre"


def degrees_from_sine(sine: F64) -> F64:
    """An angle in degrees from its sine (NaN stays NaN)."""
    with np.errstate(invalid="ignore"):
        return np.asarray(np.degrees(np.arcsin(np.clip(sine, 0.0, 1.0))))


def _safe_solve(A: F64, b: F64, usable: NDArray[np.bool_]) -> F64:
    """Solve the usable rows of a batch of square systems; the others come back NaN."""
    out = np.full(b.shape, np.nan)
    if usable.any():
        out[usable] = np.linalg.solve(A[usable], b[usable][..., None])[..., 0]
    return out


# Views given as (K, pose) and views given as P (real calibrated data) are one case. With
# N = 2: the least-squares point of two rays is their midpoint (eq. 7-8), two planes meet in
# one line (eq. 14-15), and two planes and the ground meet in one point (eq. 19).


@dataclass(frozen=True, kw_only=True)
class NViewPoints:
    """Batched N-view point estimates (see :func:`triangulate_points`)."""

    point_grid: F64  # (T, 3)
    conditioning: F64  # (T,) largest ray parallax sine over view pairs
    status: Status
    reason: Status
    rms_px: F64  # (T,) reprojection RMS over the views used


@dataclass(frozen=True, kw_only=True)
class NViewLines:
    """Batched N-view line estimates (see :func:`triangulate_lines`)."""

    point_grid: F64  # (T, 3) the point closest to the last view's camera centre
    direction_grid: F64  # (T, 3) unit
    conditioning: F64  # (T,) largest plane-angle sine over view pairs
    status: Status
    reason: Status


def projection_matrices(intrinsics: ArrayLike, R_cam_to_grid: ArrayLike, t_grid: ArrayLike) -> F64:
    """The projection matrices ``P = K [R^T | -R^T t]`` (..., 3, 4).

    ``P = K [R^T | -R^T t]`` (..., 3, 4) from (fx, fy, cx, cy), camera -> grid rotations and
    camera centres; leading dimensions broadcast.
    """
    k = np.asarray(intrinsics, dtype=np.float64)
    R = np.asarray(R_cam_to_grid, dtype=np.float64)
    t = np.asarray(t_grid, dtype=np.float64)
    lead = np.broadcast_shapes(R.shape[:-2], t.shape[:-1])
    R, t = np.broadcast_to(R, (*lead, 3, 3)), np.broadcast_to(t, (*lead, 3))
    K = np.zeros((*k.shape[:-1], 3, 3))
    K[..., 0, 0], K[..., 1, 1], K[..., 0, 2], K[..., 1, 2], K[..., 2, 2] = (
        k[..., 0],
        k[..., 1],
        k[..., 2],
        k[..., 3],
        1.0,
    )
    Rt = np.swapaxes(R, -1, -2)
    Rt_c = -np.einsum("...ij,...j->...i", Rt, t)
    return np.asarray(K @ np.concatenate([Rt, Rt_c[..., None]], axis=-1))


def _valid_views(measured: F64, valid: ArrayLike | None) -> NDArray[np.bool_]:
    """(T, N) views with finite measurements, and listed in ``valid`` if given."""
    finite = np.asarray(np.isfinite(measured).all(axis=2))
    return finite if valid is None else np.asarray(valid, dtype=bool) & finite


def _reprojection(points: F64, P: F64, px: F64) -> F64:
    """Residuals (T, N, 2) of grid points (T, 3) projected by P (T, N, 3, 4) against px."""
    X = np.concatenate([points, np.ones((points.shape[0], 1))], axis=1)
    y = np.einsum("tnij,tj->tni", P, X)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.asarray(y[..., :2] / y[..., 2:3] - px)


def triangulate_points(
    px: ArrayLike,
    P: ArrayLike,
    *,
    valid: ArrayLike | None = None,
    estimator: str = "thesis",
    iterations: int = 20,
    min_conditioning: float = DEFAULT_MIN_CONDITIONING,
) -> NViewPoints:
    """Points from N >= 2 rays, batched over trials.

    ``estimator="thesis"``: the point nearest all rays in least squares (for two rays, the
    midpoint of eq. 7-8). ``"optimal"``: that point refined by Gauss-Newton to minimise the
    reprojection error (the maximum-likelihood estimate under Gaussian pixel noise).

    Parameters
    ----------
    px : (T, N, 2) array_like
        (col, row) per view; rows of invalid views are ignored.
    P : (T, N, 3, 4) array_like
        Projection matrices, grid -> pixels.
    valid : (T, N) bool array_like, optional
        Which views a trial uses (default: those with finite pixels).
    """
    x = np.asarray(px, dtype=np.float64)
    p = np.asarray(P, dtype=np.float64)
    if x.ndim != 3 or x.shape[2] != 2 or p.shape != (*x.shape[:2], 3, 4):
        raise InputValueError(
            f"pixels must be (T, N, 2) and P (T, N, 3, 4); got {x.shape}, {p.shape}"
        )
    if estimator not in ("thesis", "optimal"):
        raise InputValueError(f"estimator must be thesis or optimal, got {estimator!r}")
    ok = _valid_views(x, valid)
    T = x.shape[0]
    c = camera_centres(p)
    xh = np.concatenate([np.where(ok[..., None], x, 0.0), np.ones((*x.shape[:2], 1))], axis=2)
    d, _ = _unit(np.linalg.solve(p[..., :3], xh[..., None])[..., 0])  # ray directions, grid
    d = np.where(ok[..., None], d, 0.0)
    # Least squares: sum_i (I - d_i d_i^T) (p - c_i) = 0.
    proj = np.eye(3) - np.einsum("tni,tnj->tnij", d, d)
    proj = np.where(ok[..., None, None], proj, 0.0)
    A = proj.sum(axis=1)
    b = np.einsum("tnij,tnj->ti", proj, np.where(ok[..., None], c, 0.0))
    conditioning = pairwise_max_sine(d, ok)
    status, reason = _view_status(
        conditioning, ok, min_conditioning, "point on the baseline (rays parallel)"
    )
    flag_no_baseline(c, ok, status, reason)
    usable = status == "ok"
    point = _safe_solve(np.where(usable[:, None, None], A, np.eye(3)), b, usable)
    if estimator == "optimal" and usable.any():
        point[usable] = _gauss_newton(point[usable], x[usable], p[usable], ok[usable], iterations)
    depth = np.einsum("tni,tni->tn", d, point[:, None, :] - c)
    behind = usable & ((depth <= 0) & ok).any(axis=1)
    status[behind], reason[behind] = "degenerate", "point behind a camera"
    point[status != "ok"] = np.nan
    with np.errstate(all="ignore"):  # rows that failed are NaN'd below
        res = np.where(
            ok[..., None],
            _reprojection(np.nan_to_num(point), p, np.where(ok[..., None], x, 0.0)),
            0.0,
        )
        rms = np.sqrt((res**2).sum(axis=(1, 2)) / np.maximum(ok.sum(axis=1), 1) / 2)
    rms[status != "ok"] = np.nan
    assert point.shape == (T, 3)
    return NViewPoints(
        point_grid=point, conditioning=conditioning, status=status, reason=reason, rms_px=rms
    )


def _gauss_newton(point: F64, x: F64, P: F64, ok: NDArray[np.bool_], iterations: int) -> F64:
    """Minimise the summed squared reprojection error over each row's valid views."""
    p = point.copy()
    w = ok.astype(np.float64)[..., None]
    x = np.where(ok[..., None], x, 0.0)  # missing views' NaN must not reach the sums
    for _ in range(iterations):
        X = np.concatenate([p, np.ones((p.shape[0], 1))], axis=1)
        y = np.einsum("tnij,tj->tni", P, X)
        z = y[..., 2:3]
        r = (y[..., :2] / z - x) * w  # (T, N, 2)
        # d(y_k / y_2)/dp = (P_k - (y_k / y_2) P_2)[:3] / y_2
        J = (P[..., :2, :3] - (y[..., :2] / z)[..., None] * P[..., 2:3, :3]) / z[..., None]
        J = J * w[..., None]
        JtJ = np.einsum("tnki,tnkj->tij", J, J) + 1e-12 * np.eye(3)
        Jtr = np.einsum("tnki,tnk->ti", J, r)
        # A row whose start lies where a camera sees it edge-on (nearly parallel rays: a
        # live warm-up's made-up pixels on a pair not toed in) has a singular or non-finite
        # normal matrix: it keeps its linear point, the others step on (a LinAlgError once
        # stopped the live pointing: a new user's r8 F3 run).
        good = np.isfinite(JtJ).all(axis=(1, 2)) & np.isfinite(Jtr).all(axis=1)
        step = np.zeros_like(p)
        try:
            step[good] = np.linalg.solve(JtJ[good], -Jtr[good][..., None])[..., 0]
        except np.linalg.LinAlgError:
            step[good] = (np.linalg.pinv(JtJ[good]) @ -Jtr[good][..., None])[..., 0]
        p += np.where(np.isfinite(step), step, 0.0)
        if np.abs(step).max() < 1e-13 * max(np.abs(p).max(), 1.0):
            break
    return p


def image_lines(px: ArrayLike, theta_deg: ArrayLike) -> F64:
    """Homogeneous image lines (..., 3) through pixel ``px`` with direction ``theta``."""
    p = np.asarray(px, dtype=np.float64)
    t = np.deg2rad(np.asarray(theta_deg, dtype=np.float64))
    a = np.concatenate([p, np.ones((*p.shape[:-1], 1))], axis=-1)
    b = a + np.stack([np.cos(t), np.sin(t), np.zeros_like(t)], axis=-1)
    return np.cross(a, b)


def segment_lines(segments_px: ArrayLike) -> F64:
    """Homogeneous image lines (..., 3) through segments ``(x0, y0, x1, y1)``."""
    s = np.asarray(segments_px, dtype=np.float64)
    ones = np.ones((*s.shape[:-1], 1))
    return np.cross(np.concatenate([s[..., :2], ones], -1), np.concatenate([s[..., 2:], ones], -1))


def triangulate_lines(
    lines: ArrayLike,
    P: ArrayLike,
    *,
    valid: ArrayLike | None = None,
    estimator: str = "thesis",
    sigma_px: ArrayLike | None = None,
    sigma_pose: ArrayLike | None = None,
    iterations: int = 10,
    min_conditioning: float = DEFAULT_MIN_CONDITIONING,
) -> NViewLines:
    """Lines from N >= 2 back-projected planes ``pi_i = P_i^T l_i``: the rank-2 null space.

    For two views the planes meet in exactly one line (eq. 14-15); for more, the line is the
    best rank-2 fit (the two smallest right singular vectors of the stacked unit planes).

    ``estimator="weighted"`` weighs each plane by how far it can move at the line: a pixel
    error ``sigma_px`` across the image line moves the plane by ``depth * sigma_px / f``
    there, a typed-translation error by ``sigma_t`` and a typed-angle error by
    ``depth * sigma_r``, so near views with steady detections and well-measured poses count
    most; then, with three views or more,
    iteratively reweighted (Huber, k = 1.345 sigma) so that one view that disagrees beyond its
    noise loses its pull. With two views it is the thesis' line (two planes meet in one line
    whatever their weights).

    Parameters
    ----------
    lines : (T, N, 3) array_like
        Homogeneous image lines (see :func:`image_lines`, :func:`segment_lines`).
    P : (T, N, 3, 4) array_like
    sigma_px : (T, N) array_like, optional
        Per view, the 1-sigma pixel error across its image line (weighted only; default 1).
    sigma_pose : (T, N, 2) array_like, optional
        Per view, the 1-sigma typed translation (grid units) and angle (radians) errors
        (weighted only; default 0).
    """
    if estimator not in ("thesis", "weighted"):
        raise InputValueError(f"line estimator must be thesis or weighted, got {estimator!r}")
    lin = np.asarray(lines, dtype=np.float64)
    p = np.asarray(P, dtype=np.float64)
    ok = _valid_views(lin, valid)
    planes = np.einsum("tnji,tnj->tni", p, np.where(ok[..., None], lin, 0.0))  # P^T l
    norm = np.linalg.norm(planes[..., :3], axis=-1, keepdims=True)
    ok &= norm[..., 0] > 0  # a zero image line (a zero-length segment) says nothing
    with np.errstate(invalid="ignore", divide="ignore"):
        planes = np.where(ok[..., None], planes / norm, 0.0)
    T = lin.shape[0]
    conditioning = pairwise_max_sine(planes[..., :3], ok)
    status, reason = _view_status(
        conditioning, ok, min_conditioning, "line coplanar with the baseline"
    )
    flag_no_baseline(camera_centres(p), ok, status, reason)
    usable = status == "ok"
    point = np.full((T, 3), np.nan)
    direction = np.full((T, 3), np.nan)
    if usable.any():
        pu, oku, planes_u = p[usable], ok[usable], planes[usable]
        c = camera_centres(pu)
        centre = np.where(oku[..., None], c, 0.0).sum(1) / oku.sum(1)[:, None]
        x0, u = _rank2_line(planes_u, centre)
        if estimator == "weighted":
            sig = np.ones(ok.shape) if sigma_px is None else np.asarray(sigma_px, np.float64)
            pose = np.zeros((*ok.shape, 2)) if sigma_pose is None else np.asarray(sigma_pose)
            x0, u = _weighted_line(
                x0, planes_u, pu, oku, c, centre, sig[usable], pose[usable], iterations
            )
        last = (oku * np.arange(ok.shape[1])).argmax(axis=1)
        c_last = c[np.arange(usable.sum()), last]
        x0 = x0 + np.einsum("ti,ti->t", c_last - x0, u)[:, None] * u  # closest to the last camera
        flip = np.take_along_axis(u, np.abs(u).argmax(axis=1)[:, None], 1) < 0
        point[usable], direction[usable] = x0, np.where(flip, -u, u)
    return NViewLines(
        point_grid=point,
        direction_grid=direction,
        conditioning=conditioning,
        status=status,
        reason=reason,
    )


#: Huber's tuning constant: 95% efficiency under Gaussian noise.
HUBER_K = 1.345


def _weighted_line(  # noqa: PLR0913 - the line fit's arrays, named as in its caller
    x0: F64,
    planes: F64,
    P: F64,
    ok: NDArray[np.bool_],
    centres: F64,
    near: F64,
    sigma_px: F64,
    sigma_pose: F64,
    iterations: int,
) -> tuple[F64, F64]:
    """The weighted/robust rank-2 line of :func:`triangulate_lines`, from its first guess.

    Each plane is weighed by its noise at the line (pixels scaled by depth over focal
    length, typed translation, typed angle scaled by depth), then, with three views or
    more, reweighted by Huber on its residual so that a disagreeing view loses its pull.
    """
    f = np.sqrt(np.abs(np.linalg.det(P[..., :3])))  # f^2 = det(K R^T)
    huber = np.ones(ok.shape)
    u = np.zeros_like(x0)
    for _ in range(iterations):
        # A point of the line in front of each camera, and the planes' noise there.
        depth = np.linalg.norm(x0[:, None] - centres, axis=-1)
        sigma = np.sqrt(
            (depth * sigma_px / f) ** 2
            + sigma_pose[..., 0] ** 2
            + (depth * sigma_pose[..., 1]) ** 2
        )
        sigma = np.where(ok & (sigma > 0), sigma, 1.0)
        w = np.where(ok, huber / sigma, 0.0)
        x0, u = _rank2_line(planes * w[..., None], near)
        if ok.sum(axis=1).min() < 3:
            continue  # two views: no redundancy to judge a view by
        # Residual of each plane: its distances to the line near the target.
        half = np.stack([-depth.mean(1), depth.mean(1)], 1)[..., None] * 0.25
        ends = x0[:, None] + half * u[:, None]
        dist = np.einsum("tni,tki->tnk", planes[..., :3], ends) + planes[..., 3:]
        r = np.sqrt((dist**2).mean(axis=2)) / sigma
        huber = np.minimum(1.0, HUBER_K / np.maximum(r, 1e-12))
    return x0, u


def _rank2_line(planes: F64, near: F64) -> tuple[F64, F64]:
    """The rank-2 fit's point nearest ``near`` and its unit direction.

    The point nearest ``near`` (T, 3) and the unit direction (T, 3) of the rank-2 fit to
    rows of planes (T, N, 4).
    """
    _, _, vt = np.linalg.svd(planes)
    a, b = vt[:, 2], vt[:, 3]  # two homogeneous points spanning the line
    u, _ = _unit(a[:, 3:4] * b[:, :3] - b[:, 3:4] * a[:, :3])
    # a finite point of the line: the spanning point with the larger |w|
    use_a = np.abs(a[:, 3]) >= np.abs(b[:, 3])
    q = np.where(use_a[:, None], a, b)
    x0 = q[:, :3] / q[:, 3:4]
    return x0 + np.einsum("ti,ti->t", near - x0, u)[:, None] * u, u


def triangulate_ground(
    lines: ArrayLike,
    P: ArrayLike,
    ground_normal_grid: ArrayLike,
    ground_offset: float,
    *,
    valid: ArrayLike | None = None,
    min_conditioning: float = DEFAULT_MIN_CONDITIONING,
) -> NViewPoints:
    """Method 2 with N >= 2 views: the planes' point on the ground plane.

    The point of the ground plane ``n3 . p = h`` nearest, in least squares, to the N
    back-projected planes; for two views exactly eq. 19's solution. The ground is a
    constraint, not a third equation among the planes: with N >= 3 an unconstrained fit
    would leave the point off the ground by the planes' disagreement.
    """
    lin = np.asarray(lines, dtype=np.float64)
    p = np.asarray(P, dtype=np.float64)
    ok = _valid_views(lin, valid)
    planes = np.einsum("tnji,tnj->tni", p, np.where(ok[..., None], lin, 0.0))
    norm_p = np.linalg.norm(planes[..., :3], axis=-1, keepdims=True)
    ok &= norm_p[..., 0] > 0  # a zero image line (a zero-length segment) says nothing
    with np.errstate(invalid="ignore", divide="ignore"):
        planes = planes / norm_p
    planes = np.where(ok[..., None], planes, 0.0)
    n3, norm = _unit(np.asarray(ground_normal_grid, dtype=np.float64))
    h = float(ground_offset) / float(norm)
    # |det [p_i; p_j; n3]| = |p_i . (p_j x n3)|: the largest over view pairs (eq. 19).
    best = pairwise_max_abs_dot(planes[..., :3], np.cross(planes[..., :3], n3), ok)
    status, reason = _view_status(best, ok, min_conditioning, "line parallel to the ground")
    plane_sine = pairwise_max_sine(planes[..., :3], ok)
    reason[(status == "degenerate") & (plane_sine < min_conditioning)] = (
        "line coplanar with the baseline"
    )
    flag_no_baseline(camera_centres(p), ok, status, reason)
    usable = status == "ok"
    point = _on_ground(planes, n3, h, usable)
    return NViewPoints(
        point_grid=point,
        conditioning=best,
        status=status,
        reason=reason,
        rms_px=np.full(len(point), np.nan),
    )


def _on_ground(planes: F64, n3: F64, h: float, usable: NDArray[np.bool_]) -> F64:
    """The (T, 3) points of the ground plane least-squares nearest the (T, N, 4) planes.

    ``p = p0 + B q`` with ``p0 = h n3`` and B an orthonormal basis of the plane; unused
    views are zero rows.
    """
    # Any vector not parallel to n3, crossed with it, spans the plane with n3 x a.
    helper = np.eye(3)[int(np.argmin(np.abs(n3)))]
    a = np.cross(n3, helper)
    a /= np.linalg.norm(a)
    B = np.stack([a, np.cross(n3, a)], axis=1)  # (3, 2)
    A = planes[..., :3] @ B  # (T, N, 2)
    b = -(planes[..., 3] + planes[..., :3] @ (h * n3))  # (T, N)
    AtA = np.einsum("tki,tkj->tij", A, A)
    Atb = np.einsum("tki,tk->ti", A, b)
    q = _safe_solve(np.where(usable[:, None, None], AtA, np.eye(2)), Atb, usable)
    return np.asarray(h * n3 + q @ B.T)
