"""The rig's constants from a checkerboard (issue 24, item 3).

A board standing at a measured place on the grid paper, seen from several typed poses.

Each capture sees every inner corner of the board; the camera's true pose is the typed one
moved by the rig's constants (:meth:`twopose.rig.RigConstants.true_poses`) and its true
intrinsics are the nominal ones changed by them (``true_intrinsics``). The fit is maximum
likelihood over every corner of every capture (``scipy.optimize.least_squares``), started
from the nominal rig (no constants), with a Gaussian prior on each constant
(:data:`RIG_PRIORS`): a tape is good to about 0.1%, a webcam's focal parameter to about
10%, a mount to a few degrees. Its covariance is ``(J^T J)^-1`` of the whitened problem,
the corners' noise estimated from the residuals. The ground height error is not seen by a
board and stays 0.

What the poses cannot determine is refused before fitting (:func:`check_identifiable`):
the mount's rotation and the tape's scale need typed moves in at least two non-parallel
directions, the camera's depth offset and the focal scale need poses at several distances
from the board. A constant the fit pushes more than two prior sigmas from nominal is said
(``warnings``), never reported silently as if the data had decided it. No I/O.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import least_squares

from twopose.arrays import F64
from twopose.errors import InputValueError
from twopose.rig.constants import (
    RIG_PARAMETERS,
    RIG_PRIORS,
    RigConstants,
    against_priors,
    prior_sigma,
)
from twopose.units import Units

__all__ = ["RIG_PRIORS", "BoardRigFit", "board_order", "check_identifiable", "fit_board_rig"]

#: The constants a board determines (RIG_PARAMETERS order, without the ground's).
FITTED = tuple(g for g in RIG_PARAMETERS if g != "ground_height_error")
FITTED_NAMES = tuple(n for g in FITTED for n in RIG_PARAMETERS[g])
#: Two typed moves are parallel when the smaller singular value of the moves is under this
#: fraction of the larger.
MIN_DIRECTION_RATIO = 0.2
#: Poses are at several distances when their depths spread over this fraction of the mean.
MIN_DEPTH_SPREAD = 0.1


@dataclass(frozen=True, kw_only=True)
class BoardRigFit:
    """The fitted constants, their 1-sigma and how well the corners fit.

    The constants are in RIG_PARAMETERS order (11); the ground height error is not fitted: 0 with
    sigma NaN.
    """

    rig: RigConstants
    sigma: F64  # (11,)
    cov: F64  # (10, 10) of the fitted constants (FITTED order: RIG_PARAMETERS but the ground)
    rms_px: float  # RMS corner residual
    n_captures: int
    n_corners: int
    free: tuple[str, ...] = FITTED_NAMES  # the fitted scalars (the rest nominal, sigma NaN)
    warnings: tuple[str, ...] = ()


def board_order(found_px: ArrayLike, inner_corners: tuple[int, int]) -> F64:
    """OpenCV's board corners put in the board's own order.

    OpenCV's corners (``cv2.findChessboardCorners``, (cols * rows, 2)) in the board's order
    (:func:`twopose.sim.layout.board_corners`: from the first inner corner, the lower left
    seen from the camera, rows along +x, rising): OpenCV starts from a corner of its
    choosing, so of the four orderings of the grid the one whose first corner is lowest and
    leftmost in the image (an upright board, an upright camera) is taken.
    """
    cols, rows = inner_corners
    grid = np.asarray(found_px, dtype=np.float64).reshape(rows, cols, 2)
    candidates = [grid[::dr, ::dc] for dr in (1, -1) for dc in (1, -1)]
    best = min(candidates, key=lambda g: float(g[0, 0, 0] - g[0, 0, 1]))  # small u, large v
    return best.reshape(-1, 2)


def _prior_sigma(units: Units) -> F64:
    """The priors' sigma of the constants a board fits (:func:`twopose.rig.prior_sigma`)."""
    return prior_sigma(units)[:-1]


def check_identifiable(t_typed: ArrayLike, board_depth: ArrayLike) -> None:
    """Refuse, naming the poses to add, when the typed poses cannot determine the rig.

    ``t_typed`` (C, 3) typed camera centres; ``board_depth`` the board's z (its plane), one
    for all captures or (C,) one per capture.
    """
    t = np.asarray(t_typed, dtype=np.float64)
    if len(t) < 3:
        raise InputValueError(
            f"a board calibration needs at least 3 captures at different typed poses, got {len(t)}"
        )
    moves = t[1:] - t[0]
    s = np.linalg.svd(moves, compute_uv=False) if len(moves) else np.zeros(1)
    if s[0] <= 0 or (len(s) < 2 or s[1] < MIN_DIRECTION_RATIO * s[0]):
        raise InputValueError(
            "the typed poses move along one direction only: the mount's rotation and the "
            "tape's scale need moves in two non-parallel directions (e.g. along x and along z)"
        )
    depth = np.asarray(board_depth, dtype=np.float64) - t[:, 2]
    if np.any(depth <= 0):
        raise InputValueError("a typed pose is at or beyond the board's plane; stand back from it")
    if (depth.max() - depth.min()) < MIN_DEPTH_SPREAD * depth.mean():
        raise InputValueError(
            "every pose is at about one distance from the board: the focal scale and the "
            "camera's depth offset need poses at several distances (move the laptop towards "
            f"or away from the board by at least {MIN_DEPTH_SPREAD * depth.mean():.2g} units)"
        )


def _project(params: F64, corners: F64, t_typed: F64, r_typed: F64, intrinsics: F64) -> F64:
    """The corners' pixels (C, K, 2) predicted for the constants ``params``.

    ``params``: the 10 constants (FITTED order), then optionally each capture's placing
    error (C, 3): where the laptop really was. ``corners`` (C, K, 3) and ``intrinsics``
    (C, 4) per capture.
    """
    n = len(FITTED_NAMES)
    rig = RigConstants.from_vector(np.append(params[:n], 0.0))
    placed = t_typed + params[n:].reshape(-1, 3) if len(params) > n else t_typed
    t, R = rig.true_poses(placed, r_typed)
    k = rig.true_intrinsics(intrinsics)[:, None, :]  # (C, 1, 4)
    p_cam = np.einsum("cji,ckj->cki", R, corners - t[:, None])  # R^T (X - t)
    z = p_cam[..., 2]
    u = k[..., 0] * p_cam[..., 0] / z + k[..., 2]
    return np.stack([u, k[..., 1] * p_cam[..., 1] / z + k[..., 3]], axis=-1)


def _per_capture(value: ArrayLike, n_captures: int, shape: tuple[int, ...], what: str) -> F64:
    """``value`` of ``shape`` (one for all captures) or ``(C, *shape)``, as ``(C, *shape)``."""
    a = np.asarray(value, dtype=np.float64)
    if a.shape == shape:
        a = np.broadcast_to(a, (n_captures, *shape))
    if a.shape[1:] != shape or len(a) != n_captures or not np.isfinite(a).all():
        raise InputValueError(f"board captures: {what} must be finite {shape} or (C, *{shape})")
    return a


def fit_board_rig(
    corners_grid: ArrayLike,
    observed_px: ArrayLike,
    t_typed: ArrayLike,
    r_typed_deg: ArrayLike,
    intrinsics: ArrayLike,
    *,
    units: Units = Units.IN,
    t_sigma: float = 0.0,
    groups: Sequence[str] = FITTED,
) -> BoardRigFit:
    """The rig's constants from board captures.

    Parameters
    ----------
    corners_grid : (K, 3) or (C, K, 3) array_like
        The board's inner corners in the grid frame (session units), for every capture or
        per capture (captures of sessions whose boards stood in different places).
    observed_px : (C, K, 2) array_like
        Each capture's detected corners, in the order of ``corners_grid`` (pixels).
    t_typed, r_typed_deg : (C, 3) array_like
        Each capture's typed camera centre and angles.
    intrinsics : (4,) or (C, 4) array_like
        The nominal ``fx, fy, cx, cy`` (the camera's calibration), for all or per capture.
    t_sigma : float
        The typed translations' 1-sigma per component (the entries' resolution: tape and
        placing): each capture's placing error is fitted with it as its prior, so the
        constants' sigma includes what the poses' typing leaves unknown (0: typed exactly).
    groups : sequence of str
        The constants' groups to fit (:data:`FITTED`, the default, or some of them); the
        rest stay nominal, with sigma NaN.
    """
    t, r = np.asarray(t_typed, dtype=np.float64), np.asarray(r_typed_deg, dtype=np.float64)
    u = np.asarray(observed_px, dtype=np.float64)
    n_corners = np.shape(corners_grid)[-2] if np.ndim(corners_grid) >= 2 else 0
    X = _per_capture(corners_grid, len(t), (n_corners, 3), "corners_grid")
    k = _per_capture(intrinsics, len(t), (4,), "intrinsics")
    if u.shape != (len(t), n_corners, 2) or r.shape != t.shape or not np.isfinite(u).all():
        raise InputValueError(
            f"board captures: want (captures, corners, 2) = ({len(t)}, {n_corners}, 2) finite "
            f"pixels, got {u.shape}"
        )
    free = _free_mask(groups)
    check_identifiable(t, X[:, :, 2].mean(axis=1))
    placing = t_sigma > 0
    nominal = np.concatenate([RigConstants().vector()[:-1], np.zeros(t.size if placing else 0)])
    prior = np.concatenate([_prior_sigma(units), np.full(t.size if placing else 0, t_sigma)])
    fitted = np.concatenate([free, np.ones(t.size if placing else 0, dtype=bool)])

    def full(p: F64) -> F64:
        out = nominal.copy()
        out[fitted] = p
        return out

    def residuals(p: F64, sigma_px: float) -> F64:
        corners = (_project(full(p), X, t, r, k) - u).ravel() / sigma_px
        return np.concatenate([corners, (p - nominal[fitted]) / prior[fitted]])

    sigma_px, p = 1.0, nominal[fitted]
    for _ in range(3):  # the corners' noise estimated from the previous fit's residuals
        fit = least_squares(residuals, p, args=(sigma_px,), x_scale=prior[fitted], method="trf")
        p = fit.x
        corner_res = (_project(full(p), X, t, r, k) - u).ravel()
        sigma_px = max(float(np.sqrt(np.mean(corner_res**2))), 1e-6)
    fit = least_squares(residuals, p, args=(sigma_px,), x_scale=prior[fitted], method="trf")
    cov = _covariance(fit.jac, free)
    sigma = np.append(np.sqrt(np.clip(np.diag(cov), 0.0, None)), np.nan)
    x = full(fit.x)
    n_rig = len(FITTED_NAMES)
    return BoardRigFit(
        rig=RigConstants.from_vector(np.append(x[:n_rig], 0.0), units),
        sigma=sigma,
        cov=cov,
        rms_px=float(np.sqrt(np.mean((_project(x, X, t, r, k) - u) ** 2))),
        n_captures=len(t),
        n_corners=u.shape[0] * u.shape[1],
        free=_names(free),
        warnings=against_priors(np.append(x[:n_rig] - nominal[:n_rig], 0.0), units, _names(free)),
    )


def _covariance(jac: F64, free: NDArray[np.bool_]) -> F64:
    """The fitted constants' covariance (10, 10; NaN where not fitted).

    ``(J^T J)^-1`` of the whitened problem, the placing errors marginalised out.
    """
    n_free = int(free.sum())
    cov = np.full((len(FITTED_NAMES), len(FITTED_NAMES)), np.nan)
    cov[np.ix_(free, free)] = np.linalg.pinv(jac.T @ jac)[:n_free, :n_free]
    return cov


def _names(free: NDArray[np.bool_]) -> tuple[str, ...]:
    return tuple(n for n, f in zip(FITTED_NAMES, free, strict=True) if f)


def _free_mask(groups: Sequence[str]) -> NDArray[np.bool_]:
    """Which of :data:`FITTED_NAMES` the groups free; a group a board cannot see is refused."""
    unknown = sorted(set(groups) - set(FITTED))
    if unknown:
        raise InputValueError(
            f"a board cannot determine {', '.join(unknown)}; it fits {', '.join(FITTED)}"
        )
    return np.array([any(n in RIG_PARAMETERS[g] for g in groups) for n in FITTED_NAMES])
