"""A board's corners seen by both cameras of a pair: the one reprojection model.

The pair's calibration (:mod:`twopose.pair.calibration`) and the floor
(:mod:`twopose.pair.floor`) fit the same thing: board poses in camera 1's frame and the
relative pose, against every corner of both cameras, with the intrinsics (distortion
included) fixed. This module holds that model, as OpenCV's ``stereoCalibrate`` has it: a
board pose ``(r_k, t_k)`` takes board points into camera 1 (``x1 = R_k X + t_k``), the
relative pose ``(r, T)`` takes camera 1 into camera 2 (``x2 = R x1 + T``), and each camera
projects by ``cv2.projectPoints``. Its Jacobian is analytic: OpenCV's derivatives of the
projection, chained through ``cv2.composeRT``'s. No I/O.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import ArrayLike

from twopose.arrays import F32, F64
from twopose.camera.model import Intrinsics
from twopose.detect.checkerboard import board_pattern
from twopose.errors import InputValueError
from twopose.values.bounds import INNER_CORNERS

__all__ = [
    "BoardCorners",
    "LensModel",
    "board_poses",
    "central_jacobian",
    "disagreeing_views",
    "reprojection",
    "rotation_matrix",
    "rotation_vector",
    "view_relative_poses",
]


@dataclass(frozen=True, kw_only=True, eq=False)
class LensModel:
    """A camera's fixed intrinsics as OpenCV's projection takes them."""

    K: F64  # (3, 3)
    distortion: F64  # (5,) k1, k2, p1, p2, k3

    @classmethod
    def of(cls, intrinsics: Intrinsics) -> LensModel:
        """The model of ``intrinsics`` (plumb bob)."""
        return cls(K=intrinsics.K, distortion=np.array(intrinsics.distortion, dtype=np.float64))

    def project(self, points: F32, rvec: F64, tvec: F64) -> tuple[F64, F64]:
        """Pixels (M, 2) of board ``points`` (M, 3) at pose ``(rvec, tvec)``.

        And their derivatives (2 M, 6) with respect to ``(rvec, tvec)``.
        """
        px, jac = cv2.projectPoints(points, rvec, tvec, self.K, self.distortion)
        return np.asarray(px, np.float64).reshape(-1, 2), np.asarray(jac[:, :6], np.float64)

    def undistort(self, px: ArrayLike) -> F64:
        """Pixels (..., 2) with the lens' distortion removed (the pinhole model's pixels)."""
        p = np.asarray(px, dtype=np.float64)
        if not np.any(self.distortion) or p.size == 0:  # OpenCV returns one point for none
            return p
        flat = p.reshape(-1, 1, 2)
        # Iterated to 1e-12 (OpenCV's default stops after five steps: 1e-3 px off at a
        # wide lens' edge, a thousandth of an inch at 14 in).
        criteria = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-12)
        out = cv2.undistortPoints(
            flat, self.K, self.distortion, R=None, P=self.K, criteria=criteria
        )
        return np.asarray(out, np.float64).reshape(p.shape)


@dataclass(frozen=True, kw_only=True, eq=False)
class BoardCorners:
    """The board's corners found in both cameras over V views (stills).

    ``board`` its inner corners (cols, rows), ``pattern`` (M, 3) their places on its plane
    in the pair's units (:func:`twopose.detect.checkerboard.board_pattern`), ``left`` and
    ``right`` (V, M, 2) their pixels in camera 1 and camera 2, in the pattern's order.
    """

    board: tuple[int, int]
    pattern: F32
    left: F64
    right: F64

    @classmethod
    def of(
        cls,
        board: tuple[int, int],
        square: float,
        left: Sequence[ArrayLike],
        right: Sequence[ArrayLike],
    ) -> BoardCorners:
        """Checked corners: as many views in both cameras, every view the board's corners."""
        cols, rows = board
        low = INNER_CORNERS.low  # OpenCV's board search needs more than 2 each way
        if cols < low or rows < low:
            raise InputValueError(
                f"the board needs at least {low:g}x{low:g} inner corners, got {cols}x{rows}"
            )
        if not (np.isfinite(square) and square > 0):
            raise InputValueError(f"the board's square must be a positive length, got {square}")
        if len(left) != len(right):
            raise InputValueError(
                f"{len(left)} views of the board in camera 1 but {len(right)} in camera 2: "
                "each view needs both cameras' corners"
            )
        M = cols * rows
        views = []
        for camera, corners in (("camera 1", left), ("camera 2", right)):
            arrays = [np.asarray(c, dtype=np.float64).reshape(-1, 2) for c in corners]
            for k, a in enumerate(arrays):
                if a.shape[0] != M or not np.isfinite(a).all():
                    raise InputValueError(
                        f"view {k + 1}, {camera}: {a.shape[0]} corners where a {cols}x{rows} "
                        f"board has {M} (or a non-finite one)"
                    )
            views.append(np.stack(arrays) if arrays else np.zeros((0, M, 2)))
        return cls(
            board=(cols, rows), pattern=board_pattern(board, square), left=views[0], right=views[1]
        )

    @property
    def n_views(self) -> int:
        """How many views (stills) of the board."""
        return int(self.left.shape[0])

    def subset(self, keep: ArrayLike) -> BoardCorners:
        """The views ``keep`` (indices or a mask)."""
        k = np.asarray(keep)
        return BoardCorners(
            board=self.board, pattern=self.pattern, left=self.left[k], right=self.right[k]
        )


def rotation_matrix(rvec: ArrayLike) -> F64:
    """The rotations (..., 3, 3) of rotation vectors (..., 3) in radians."""
    from scipy.spatial.transform import Rotation

    v = np.asarray(rvec, dtype=np.float64)
    R = Rotation.from_rotvec(v.reshape(-1, 3)).as_matrix()
    return np.asarray(R, np.float64).reshape(*v.shape[:-1], 3, 3)


def rotation_vector(R: ArrayLike) -> F64:
    """The rotation vectors (..., 3) of rotations (..., 3, 3), in radians.

    Exact near the identity too (OpenCV's ``Rodrigues`` returns zero below 1e-5 rad, which
    would cut the small rotations a covariance is made of).
    """
    from scipy.spatial.transform import Rotation

    m = np.asarray(R, dtype=np.float64)
    v = Rotation.from_matrix(m.reshape(-1, 3, 3)).as_rotvec()
    return np.asarray(v, np.float64).reshape(*m.shape[:-2], 3)


def board_poses(corners: BoardCorners, lens: LensModel, which: str) -> F64:
    """Each view's board pose (V, 6) ``(rvec, tvec)`` in one camera, by ``cv2.solvePnP``."""
    pixels = corners.left if which == "left" else corners.right
    poses = np.zeros((corners.n_views, 6))
    for k, px in enumerate(pixels):
        ok, r, t = cv2.solvePnP(corners.pattern, px.reshape(-1, 1, 2), lens.K, lens.distortion)
        if not ok:
            raise InputValueError(f"view {k + 1}: the board's pose in the {which} camera failed")
        poses[k] = np.r_[np.ravel(r), np.ravel(t)]
    return poses


def reprojection(
    relative: F64,
    boards: F64,
    corners: BoardCorners,
    lenses: tuple[LensModel, LensModel],
    *,
    jacobian: bool = True,
) -> tuple[F64, F64 | None]:
    """Every corner's reprojection residual and the Jacobian.

    Parameters
    ----------
    relative : (6,) ndarray
        ``(r, T)``: camera 1 into camera 2, ``x2 = R x1 + T`` (OpenCV's stereo pose).
    boards : (V, 6) ndarray
        Each view's board pose ``(r_k, t_k)`` in camera 1.
    corners : BoardCorners
    lenses : (LensModel, LensModel)
        Camera 1's and camera 2's fixed intrinsics.
    jacobian : bool
        Whether to compute the Jacobian.

    Returns
    -------
    (V 4 M,) ndarray, (V 4 M, 6 + 6 V) ndarray or None
        Residuals (projected minus found, pixels), view by view: camera 1's M corners
        (col, row), then camera 2's; the Jacobian's columns are ``relative`` then each
        view's board pose.
    """
    V, M = corners.n_views, corners.pattern.shape[0]
    res = np.zeros(V * 4 * M)
    J = np.zeros((V * 4 * M, 6 + 6 * V)) if jacobian else None
    rr, tr = relative[:3].reshape(3, 1), relative[3:].reshape(3, 1)
    for k in range(V):
        rk, tk = boards[k, :3].reshape(3, 1), boards[k, 3:].reshape(3, 1)
        row = 4 * M * k
        p1, j1 = lenses[0].project(corners.pattern, rk, tk)
        r2, t2, *d = cv2.composeRT(rk, tk, rr, tr)
        p2, j2 = lenses[1].project(corners.pattern, np.asarray(r2), np.asarray(t2))
        res[row : row + 2 * M] = (p1 - corners.left[k]).ravel()
        res[row + 2 * M : row + 4 * M] = (p2 - corners.right[k]).ravel()
        if J is not None:
            # composeRT's derivatives: (r3, t3) by (r1, t1) and by (r2, t2).
            dr3dr1, dr3dt1, dr3dr2, dr3dt2, dt3dr1, dt3dt1, dt3dr2, dt3dt2 = d
            by_board = np.block([[dr3dr1, dr3dt1], [dt3dr1, dt3dt1]])
            by_relative = np.block([[dr3dr2, dr3dt2], [dt3dr2, dt3dt2]])
            J[row : row + 2 * M, 6 + 6 * k : 12 + 6 * k] = j1
            J[row + 2 * M : row + 4 * M, 6 + 6 * k : 12 + 6 * k] = j2 @ by_board
            J[row + 2 * M : row + 4 * M, :6] = j2 @ by_relative
    return res, J


@dataclass(frozen=True, kw_only=True, eq=False)
class JointFit:
    """The joint least squares over every board pose and the relative pose.

    ``relative`` (6,) ``(r, T)`` of OpenCV's stereo pose, ``boards`` (V, 6) the board
    poses in camera 1, ``cov`` (6 + 6 V, 6 + 6 V) their covariance ``s^2 (J^T J)^-1``
    (``s^2`` the residuals' variance: sum of squares over residuals minus parameters),
    ``rms_px`` as OpenCV reports it (the root mean square corner distance over both
    cameras), ``view_rms_px`` (V,) each view's.
    """

    relative: F64
    boards: F64
    cov: F64
    rms_px: float
    view_rms_px: F64


#: The joint fit's stopping tolerances (MINPACK's LM): tight, so that it stops at the
#: minimum OpenCV's ``stereoCalibrate`` stops at, to its own precision.
_TOLERANCE = 1e-15
#: The normal equations are singular beyond this condition number (scaled columns).
_SINGULAR = 1e12


def fit_joint(
    corners: BoardCorners,
    lenses: tuple[LensModel, LensModel],
    start: tuple[F64, F64] | None = None,
) -> JointFit:
    """The relative pose and every board pose that minimise both cameras' reprojection.

    The cost of ``cv2.stereoCalibrate`` with ``CALIB_FIX_INTRINSIC`` (so its answer), by
    ``scipy.optimize.least_squares`` (Levenberg-Marquardt) with the analytic Jacobian of
    :func:`reprojection`; started from ``start`` ``(relative, boards)``, or from each
    view's ``solvePnP`` in both cameras (the relative pose of the view that agrees most
    with the others).

    Raises
    ------
    InputValueError
        Fewer than 1 view, or views that do not fix the poses (singular normal equations).
    """
    from scipy.optimize import least_squares

    V = corners.n_views
    if V < 1:
        raise InputValueError("no view of the board in both cameras")
    relative, boards = start if start is not None else _first_guess(corners, lenses)
    x0 = np.r_[relative, boards.ravel()]

    def residuals(x: F64) -> F64:
        return reprojection(x[:6], x[6:].reshape(V, 6), corners, lenses, jacobian=False)[0]

    def jac(x: F64) -> F64:
        J = reprojection(x[:6], x[6:].reshape(V, 6), corners, lenses)[1]
        assert J is not None
        return J

    solved = least_squares(
        residuals, x0, jac=jac, method="lm", xtol=_TOLERANCE, ftol=_TOLERANCE, gtol=_TOLERANCE
    )
    x = np.asarray(solved.x, dtype=np.float64)
    r = np.asarray(solved.fun, dtype=np.float64)
    J = jac(x)
    scale = np.linalg.norm(J, axis=0)
    if not (scale > 0).all():
        raise InputValueError("the board's views do not fix the pair's poses")
    Js = J / scale
    normal = Js.T @ Js
    if np.linalg.cond(normal) > _SINGULAR:
        raise InputValueError(
            "the board's views do not fix the pair's poses (the fit is singular): show the "
            "board whole to both cameras, at several places and tilts"
        )
    dof = max(r.size - x.size, 1)
    cov = (r @ r / dof) * np.linalg.inv(normal) / np.outer(scale, scale)
    per_corner = (r.reshape(V, 2 * corners.pattern.shape[0], 2) ** 2).sum(axis=2)
    return JointFit(
        relative=x[:6],
        boards=x[6:].reshape(V, 6),
        cov=cov,
        rms_px=float(np.sqrt(per_corner.mean())),
        view_rms_px=np.sqrt(per_corner.mean(axis=1)),
    )


def _first_guess(corners: BoardCorners, lenses: tuple[LensModel, LensModel]) -> tuple[F64, F64]:
    """Each view's board pose in camera 1, and a relative pose to start from.

    The relative pose of the view whose own (both cameras' ``solvePnP``) is nearest the
    others' (a misfit view, such as one with its corners found in reverse, does not pull
    the start).
    """
    left, relative = view_relative_poses(corners, lenses)
    best = int(np.argmin(_disagreement(relative).sum(axis=1)))
    return relative[best], left


def view_relative_poses(
    corners: BoardCorners, lenses: tuple[LensModel, LensModel]
) -> tuple[F64, F64]:
    """Each view's board pose in camera 1 (V, 6) and its own relative pose (V, 6).

    The relative pose ``(r, T)`` that view alone gives: its board's pose in camera 2
    (``solvePnP``) composed with the inverse of its pose in camera 1.
    """
    left = board_poses(corners, lenses[0], "left")
    right = board_poses(corners, lenses[1], "right")
    R = rotation_matrix(right[:, :3]) @ np.swapaxes(rotation_matrix(left[:, :3]), -1, -2)
    T = right[:, 3:] - np.einsum("kij,kj->ki", R, left[:, 3:])
    return left, np.column_stack([rotation_vector(R), T])


def _disagreement(relative: F64) -> F64:
    """(V, V) how far apart the views' own relative poses are (rotation + scaled shift)."""
    R = rotation_matrix(relative[:, :3])
    T = relative[:, 3:]
    spread = np.linalg.norm(R[:, None] - R[None], axis=(2, 3))
    scale = float(np.median(np.linalg.norm(T, axis=1))) or 1.0
    return np.asarray(spread + np.linalg.norm(T[:, None] - T[None], axis=2) / scale)


def disagreeing_views(
    corners: BoardCorners, lenses: tuple[LensModel, LensModel], *, max_deg: float, max_share: float
) -> list[tuple[int, str]]:
    """The views whose own relative pose is far from the others' (each with how far).

    Far: a rotation beyond ``max_deg`` degrees from the view that agrees most with the
    others, or a centre beyond ``max_share`` of the baseline from it: a corner grid found
    in reverse in one camera, a board that moved between the two photographs, another
    board. A least-squares fit would spread such a view over every other.
    """
    _, relative = view_relative_poses(corners, lenses)
    best = int(np.argmin(_disagreement(relative).sum(axis=1)))
    R0 = rotation_matrix(relative[best, :3])
    angle = np.degrees(np.linalg.norm(
        rotation_vector(rotation_matrix(relative[:, :3]) @ R0.T), axis=1
    ))  # fmt: skip
    baseline = float(np.linalg.norm(relative[best, 3:])) or 1.0
    shift = np.linalg.norm(relative[:, 3:] - relative[best, 3:], axis=1) / baseline
    return [
        (k, f"its own relative pose {angle[k]:.1f} deg and {shift[k]:.0%} of the baseline "
            "from the others'")
        for k in range(corners.n_views)
        if angle[k] > max_deg or shift[k] > max_share
    ]  # fmt: skip


def extrinsic_of(relative: F64) -> tuple[F64, F64]:
    """``(R_2_to_1, t_2_in_1)`` of OpenCV's stereo pose ``(r, T)`` (``x2 = R x1 + T``).

    ``p1 = R_2_to_1 p2 + t_2_in_1`` (the thesis' ``p1 = R p2 + d``): camera 2's axes and
    centre in camera 1's frame.
    """
    R = rotation_matrix(relative[:3])
    return R.T, -R.T @ relative[3:]


def extrinsic_jacobian(relative: F64, step: float = 1e-7) -> F64:
    """(6, 6) the pair's parameters by OpenCV's ``(r, T)``, by central differences.

    The pair's parameters are ``(delta, t_2_in_1)``: ``delta`` the rotation vector of a
    small rotation in camera 1's frame (``R_2_to_1 = exp([delta]x) R_2_to_1``), then
    camera 2's centre.
    """
    R0, _ = extrinsic_of(relative)

    def pair_parameters(x: F64) -> F64:
        R, t = extrinsic_of(x)
        return np.asarray(np.r_[rotation_vector(R @ R0.T), t], dtype=np.float64)

    return central_jacobian(pair_parameters, relative, step)


def central_jacobian(function: Callable[[F64], F64], x: F64, step: float | F64) -> F64:
    """(M, N) the derivatives of ``function`` (N,) -> (M,) at ``x``, by central differences.

    ``step`` one for every parameter, or (N,) one each; the one numerical derivative of
    the pair's covariances (its parameters, the floor's, a typed pose's angles, the held-out
    spacings').
    """
    x = np.asarray(x, dtype=np.float64)
    h = np.broadcast_to(np.asarray(step, dtype=np.float64), x.shape)
    columns = []
    for i in range(x.size):
        e = np.zeros_like(x)
        e[i] = h[i]
        columns.append((np.asarray(function(x + e)) - np.asarray(function(x - e))) / (2 * h[i]))
    return np.asarray(np.stack(columns, axis=-1), dtype=np.float64)


def extrinsic_cov(fit: JointFit) -> F64:
    """(6, 6) the covariance of the pair's parameters (:func:`extrinsic_jacobian`)."""
    G = extrinsic_jacobian(fit.relative)
    return np.asarray(G @ fit.cov[:6, :6] @ G.T)
