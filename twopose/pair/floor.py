"""The floor plane from a board lying on it, seen by the calibrated pair.

The board's pose in camera 1's frame is fitted to its corners in camera 1 and, when given,
camera 2 (through the pair's relative pose, held fixed: the reprojection model of
:mod:`twopose.pair.board_fit`); the board's plane, moved down by the board's thickness, is
the floor: ``normal . p = height`` in camera 1's frame, the normal pointing from camera 1
toward the floor. Its covariance is the fit's (``s^2 (J^T J)^-1``, ``s^2`` the residuals'
variance) plus, with camera 2, the pair's extrinsic covariance carried through the fit
(``d pose / d extrinsic = -(J_b^T J_b)^-1 J_b^T J_e``); the floor's correlation with the
extrinsics is not kept (each is carried into an estimate as its own error). With camera
2's still, the board's pose from each camera alone must agree through the pair's pose
(stills of two moments are refused). No I/O.
"""

from __future__ import annotations

import dataclasses

import cv2
import numpy as np
from numpy.typing import ArrayLike

from twopose.arrays import F64
from twopose.errors import InputValueError
from twopose.pair.board_fit import (
    BoardCorners,
    LensModel,
    central_jacobian,
    extrinsic_jacobian,
    reprojection,
    rotation_matrix,
    rotation_vector,
)
from twopose.pair.calibration import FloorPlane, PairCalibration

__all__ = ["FLOOR_AGREEMENT_ODDS", "MIN_CORNER_SIGMA_PX", "floor_from_board", "with_floor"]

#: Floor stills whose board poses (camera 1's, camera 2's through R, t) are further apart
#: than chi-square(6)'s 1-in-this quantile are refused (3.9 sigma: OpenCV's 13 pairs'
#: boards agree within 1.9 sigma, any two of its moments differ by 300 or more).
FLOOR_AGREEMENT_ODDS = 10_000
#: The least 1-sigma of a corner (pixels) the floor boards' agreement assumes (a board
#: drawn without noise fits to zero).
MIN_CORNER_SIGMA_PX = 0.05


def floor_from_board(
    pair: PairCalibration,
    left: ArrayLike,
    right: ArrayLike | None,
    board: tuple[int, int],
    square: float,
    *,
    thickness: float = 0.0,
) -> FloorPlane:
    """The floor from one view of a board lying flat on it (the module docstring).

    Parameters
    ----------
    pair : PairCalibration
        The calibrated pair (its units are the board's and the thickness').
    left : (M, 2) or (M, 1, 2) array_like
        The board's corners in camera 1.
    right : (M, 2) or (M, 1, 2) array_like, optional
        The same view's corners in camera 2 (None: camera 1 alone).
    board : (cols, rows)
        The board's inner corners.
    square : float
        The side of a square, in the pair's units.
    thickness : float
        The board's printed face above the floor, in the pair's units (>= 0).

    Returns
    -------
    FloorPlane
    """
    if not (np.isfinite(thickness) and thickness >= 0):
        raise InputValueError(f"the board's thickness must be a length >= 0, got {thickness}")
    both = right is not None
    corners = BoardCorners.of(board, square, [left], [right if right is not None else left])
    lenses = (LensModel.of(pair.intrinsics1), LensModel.of(pair.intrinsics2))
    R_rel = pair.R_2_to_1.T
    relative = np.r_[rotation_vector(R_rel), -R_rel @ pair.t_2_in_1]
    ok, r0, t0 = cv2.solvePnP(
        corners.pattern, corners.left[0].reshape(-1, 1, 2), lenses[0].K, lenses[0].distortion
    )
    if not ok:
        raise InputValueError("the floor board's pose in camera 1 failed")
    start = np.r_[np.ravel(r0), np.ravel(t0)]
    if both:
        _refuse_disagreement(pair, relative, start, corners, lenses)
    pose, J_b, J_e, res = _fit_board(relative, start, corners, lenses, both=both)
    normal = J_b.T @ J_b
    if np.linalg.cond(normal) > 1e12:
        raise InputValueError("the floor board's view does not fix its pose: show it whole")
    inverse = np.linalg.inv(normal)
    cov_pose = (res @ res / max(res.size - 6, 1)) * inverse
    if both:
        # The pair's extrinsic error moves the fitted board: its covariance in OpenCV's
        # (r, T) parameters, carried through the fit's implicit derivative.
        G = np.linalg.inv(extrinsic_jacobian(relative))
        A = -inverse @ J_b.T @ J_e
        cov_pose = cov_pose + A @ (G @ pair.cov_extrinsic @ G.T) @ A.T
    n, h = _plane(pose, thickness)
    F = _plane_jacobian(pose, thickness, n)
    return FloorPlane(normal=n, height=h, cov=F @ cov_pose @ F.T)


def with_floor(pair: PairCalibration, floor: FloorPlane | None) -> PairCalibration:
    """``pair`` with its floor set (or removed)."""
    return dataclasses.replace(pair, floor=floor)


def _refuse_disagreement(
    pair: PairCalibration,
    relative: F64,
    start: F64,
    corners: BoardCorners,
    lenses: tuple[LensModel, LensModel],
) -> None:
    """Refuse floor stills whose board poses disagree (two moments, or the board moved).

    Camera 1's pose of the board alone and camera 2's alone (through the pair's R, t) must
    agree within their covariances (each its own fit's, its corners' variance at least
    :data:`MIN_CORNER_SIGMA_PX` squared, camera 2's with the extrinsics' carried, both
    times the pair's variance factor): their Mahalanobis distance within chi-square(6)'s
    1-in-:data:`FLOOR_AGREEMENT_ODDS` quantile.
    """
    from scipy import special

    poses, covs = [], []
    for camera in (1, 2):
        pose, J_b, J_e, res = _fit_board(relative, start, corners, lenses, camera=camera)
        inverse = np.linalg.inv(J_b.T @ J_b)
        variance = max(float(res @ res) / max(res.size - 6, 1), MIN_CORNER_SIGMA_PX**2)
        cov = variance * inverse * pair.cov_factor
        if camera == 2:
            G = np.linalg.inv(extrinsic_jacobian(relative))
            A = -inverse @ J_b.T @ J_e
            cov = cov + A @ (G @ pair.cov_extrinsic @ G.T) @ A.T
        poses.append(pose)
        covs.append(cov)
    d = poses[0] - poses[1]
    distance = float(d @ np.linalg.solve(covs[0] + covs[1], d))
    bound = float(special.chdtri(6, 1.0 / FLOOR_AGREEMENT_ODDS))
    if not distance <= bound:
        raise InputValueError(
            f"the floor board's pose from camera 1 and from camera 2 disagree through the "
            f"pair's pose (by {np.linalg.norm(d[3:]):.3g} {pair.units} and "
            f"{np.degrees(np.linalg.norm(d[:3])):.2g} deg, {np.sqrt(distance):.0f} sigma "
            f"where {np.sqrt(bound):.1f} is the most): are --floor-left and --floor-right of "
            "the same moment, the board still between them?"
        )


def _fit_board(
    relative: F64,
    start: F64,
    corners: BoardCorners,
    lenses: tuple[LensModel, LensModel],
    *,
    both: bool = False,
    camera: int = 1,
) -> tuple[F64, F64, F64, F64]:
    """The board's pose by least squares.

    The pose, the Jacobians by it and by the relative pose, and the residuals (``camera``'s
    corners, or both cameras' with ``both``).
    """
    from scipy.optimize import least_squares

    m = 2 * corners.pattern.shape[0]
    rows = slice(None) if both else slice(0, m) if camera == 1 else slice(m, None)

    def evaluate(x: F64) -> tuple[F64, F64]:
        r, J = reprojection(relative, x[None], corners, lenses)
        assert J is not None
        return r[rows], J[rows]

    tight = 1e-15  # to the minimum (a noise-free board's floor to the nanometre)
    solved = least_squares(
        lambda x: evaluate(x)[0], start, jac=lambda x: evaluate(x)[1][:, 6:], method="lm",
        xtol=tight, ftol=tight, gtol=tight,
    )  # fmt: skip
    pose = np.asarray(solved.x, dtype=np.float64)
    res, J = evaluate(pose)
    return pose, J[:, 6:], J[:, :6], res


def _plane(pose: F64, thickness: float) -> tuple[F64, float]:
    """The floor under a board at ``pose``: its normal toward the floor, its distance."""
    R = rotation_matrix(pose[:3])
    n = R[:, 2]
    h = float(n @ pose[3:])
    if h < 0:
        n, h = -n, -h
    return n, h + thickness


def _plane_jacobian(pose: F64, thickness: float, n0: F64, step: float = 1e-7) -> F64:
    """(4, 6) the floor's (normal, height) by the board's pose, by central differences."""

    def plane(x: F64) -> F64:
        n, h = _plane(x, thickness)
        side = -1.0 if n @ n0 < 0 else 1.0  # the estimate's side of the normal
        return np.asarray(np.r_[side * n, h], dtype=np.float64)

    return central_jacobian(plane, pose, step)
