"""The pair's calibration checked by leave-one-out: whether its covariance tells the truth.

Each view in turn is held out: the pair is fitted on the others (:func:`twopose.pair.
board_fit.fit_joint`), the held-out board's corners are reconstructed from its two
photographs (:func:`twopose.solve.two_view.triangulate_two_views`, the thesis' midpoint), and
every spacing between neighbouring corners is compared with the board's true square. Each
spacing's 1-sigma is predicted to first order from two sources: the pixels (each corner's
1-sigma the larger of the fold's RMS per coordinate and that corner's misfit in its own
photograph, the board's single-view pose by ``solvePnP``: large where the corner finder
misplaced a corner) and the fold's own extrinsic covariance; and, a spacing being a length, the
corners' errors across it lengthen it (second order: the error is compared less that
expected lengthening, its spread added). The check passes when every held-out
spacing is within :data:`CHECK_SIGMAS` of its sigma. The folds' spread of the relative pose
(the jackknife's covariance) is set beside the fit's covariance too. No I/O.

The intrinsics are held as given in every fold (the pair's fit holds them fixed).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass, field

import cv2
import numpy as np
from numpy.typing import ArrayLike

from twopose.arrays import F64
from twopose.errors import InputValueError
from twopose.pair.board_fit import (
    BoardCorners,
    JointFit,
    LensModel,
    central_jacobian,
    extrinsic_cov,
    extrinsic_of,
    fit_joint,
    rotation_matrix,
    rotation_vector,
)
from twopose.solve.nview import projection_matrices
from twopose.solve.two_view import triangulate_two_views

__all__ = [
    "CHECK_SIGMAS",
    "HoldoutCheck",
    "corner_sigma_px",
    "leave_one_out",
    "pixel_jacobian",
    "pnp_residual_px",
    "spacing_second_order",
    "spacing_sigma",
    "spacings",
    "triangulated",
]

#: A held-out spacing further than this many of its predicted sigmas from the true square
#: fails the check.
CHECK_SIGMAS = 3.0


@dataclass(frozen=True, kw_only=True)
class HoldoutCheck:
    """The leave-one-out check of a pair's calibration (the module docstring).

    ``folds`` views held out in turn, ``spacings`` held-out spacings compared; the largest
    ``|error| / sigma`` (``worst_sigmas``), how many are beyond :data:`CHECK_SIGMAS`
    (``beyond``), the median ``|error|`` and median predicted sigma (the pair's units);
    ``jackknife_ratio``, per extrinsic parameter (rotation vector x, y, z, then t x, y, z),
    the folds' jackknife 1-sigma over the fit's. ``errors`` and ``sigmas``, every spacing's
    (fold after fold), are kept in memory only (a pair file keeps the summary).
    """

    folds: int
    spacings: int
    worst_sigmas: float
    beyond: int
    median_error: float
    median_sigma: float
    jackknife_ratio: tuple[float, ...]
    errors: tuple[float, ...] = field(default=(), repr=False)
    sigmas: tuple[float, ...] = field(default=(), repr=False)

    @classmethod
    def of(cls, folds: int, errors: F64, sigmas: F64, jackknife_ratio: F64) -> HoldoutCheck:
        """The check's summary of every held-out spacing's error and sigma."""
        z = np.abs(errors) / sigmas
        return cls(
            folds=folds,
            spacings=int(errors.size),
            worst_sigmas=float(z.max()) if z.size else float("nan"),
            beyond=int((z > CHECK_SIGMAS).sum()),
            median_error=float(np.median(np.abs(errors))) if errors.size else float("nan"),
            median_sigma=float(np.median(sigmas)) if sigmas.size else float("nan"),
            jackknife_ratio=tuple(float(x) for x in jackknife_ratio),
            errors=tuple(float(x) for x in errors),
            sigmas=tuple(float(x) for x in sigmas),
        )

    @property
    def passed(self) -> bool:
        """Whether every held-out spacing is within :data:`CHECK_SIGMAS` of its sigma."""
        return self.spacings > 0 and self.worst_sigmas <= CHECK_SIGMAS

    def unconfirmed(self) -> str:
        """What a failed check means for the regions, in words ("" when it passed).

        Every region of the pair's sessions carries its covariance, which the check found
        too small or could not test.
        """
        if self.passed:
            return ""
        found = (
            f"a held-out spacing {self.worst_sigmas:.1f} sigma off, {self.beyond} of "
            f"{self.spacings} beyond {CHECK_SIGMAS:g}"
            if self.spacings
            else "no held-out spacing to compare"
        )
        return (
            f"the pair's covariance is not confirmed (its leave-one-out check found {found}): "
            "the regions that carry it may be too small; calibrate the pair again with more "
            "stills, nearer, the board filling more of both images"
        )

    def scaled(self, factor: float) -> HoldoutCheck:
        """The same check with its lengths times ``factor`` (a change of units)."""
        return dataclasses.replace(
            self,
            median_error=self.median_error * factor,
            median_sigma=self.median_sigma * factor,
            errors=tuple(e * factor for e in self.errors),
            sigmas=tuple(s * factor for s in self.sigmas),
        )


def spacings(points: F64, board: tuple[int, int]) -> F64:
    """(S,) distances between row and column neighbours of the (M, 3) grid of corners.

    Along the rows first (``(cols - 1) rows`` of them), then across.
    """
    cols, rows = board
    g = np.asarray(points, dtype=np.float64).reshape(rows, cols, 3)
    along = np.linalg.norm(np.diff(g, axis=1), axis=2).ravel()
    across = np.linalg.norm(np.diff(g, axis=0), axis=2).ravel()
    return np.concatenate([along, across])


def _spacing_covariances(
    points: F64, jac: F64, sigma_px: F64, board: tuple[int, int]
) -> tuple[F64, F64]:
    """Each spacing's vector (S, 3) and its two corners' summed covariance (S, 3, 3).

    Each corner's covariance ``s^2 J J^T`` (``jac`` (M, 3, 4): its point by its four
    pixels, ``sigma_px`` (M,) its pixels' 1-sigma); spacings in :func:`spacings`' order.
    """
    cols, rows = board
    cov = (sigma_px**2)[:, None, None] * np.einsum("pik,pjk->pij", jac, jac)
    g, c = points.reshape(rows, cols, 3), cov.reshape(rows, cols, 3, 3)
    vectors, sums = [], []
    for a, b, ca, cb in (
        (g[:, :-1], g[:, 1:], c[:, :-1], c[:, 1:]),
        (g[:-1], g[1:], c[:-1], c[1:]),
    ):
        vectors.append((b - a).reshape(-1, 3))
        sums.append((ca + cb).reshape(-1, 3, 3))
    return np.concatenate(vectors), np.concatenate(sums)


def spacing_sigma(points: F64, jac: F64, sigma_px: F64, board: tuple[int, int]) -> F64:
    """(S,) first-order 1-sigma of each spacing from its corners' pixels.

    Each corner's covariance ``s^2 J J^T`` (``jac`` (M, 3, 4): its point by its four
    pixels, ``sigma_px`` (M,) its pixels' 1-sigma), carried along the spacing.
    """
    d, C = _spacing_covariances(points, jac, sigma_px, board)
    u = d / np.linalg.norm(d, axis=-1, keepdims=True)
    return np.asarray(np.sqrt(np.einsum("si,sij,sj->s", u, C, u)))


def spacing_second_order(
    points: F64, jac: F64, sigma_px: F64, board: tuple[int, int]
) -> tuple[F64, F64]:
    """(S,) each spacing's second-order bias and variance from its corners' pixels.

    A spacing is a length: the corners' errors across it (``e_perp``) lengthen it by
    ``|e_perp|^2 / 2L``, on average ``tr C_perp / 2L`` with variance
    ``tr(C_perp^2) / 2L^2``: small at a wide baseline, but a far board tilted away from a
    narrow pair has millimetres of depth error across a 25 mm spacing.
    """
    d, C = _spacing_covariances(points, jac, sigma_px, board)
    L = np.linalg.norm(d, axis=-1)
    u = d / L[:, None]
    across = np.eye(3) - np.einsum("si,sj->sij", u, u)
    Cp = across @ C @ across
    bias = np.trace(Cp, axis1=1, axis2=2) / (2 * L)
    variance = np.einsum("sij,sji->s", Cp, Cp) / (2 * L**2)
    return np.asarray(bias), np.asarray(variance)


def pnp_residual_px(corners: ArrayLike, pattern: ArrayLike, lens: LensModel) -> F64:
    """(M,) each corner's distance (px) from the board's best single-view pose."""
    obj = np.asarray(pattern, np.float32)
    px = np.asarray(corners, np.float64).reshape(-1, 1, 2)
    _, rvec, tvec = cv2.solvePnP(obj, px, lens.K, lens.distortion)
    projected, _ = cv2.projectPoints(obj, rvec, tvec, lens.K, lens.distortion)
    return np.asarray(np.linalg.norm(projected.reshape(-1, 2) - px.reshape(-1, 2), axis=1))


def corner_sigma_px(
    floor_px: float,
    left: ArrayLike,
    right: ArrayLike,
    pattern: ArrayLike,
    lenses: tuple[LensModel, LensModel],
) -> F64:
    """(M,) each corner's pixel 1-sigma.

    The larger of ``floor_px`` (from the fit's RMS) and the corner's misfit in its own
    photograph (either camera's).
    """
    return np.maximum(
        float(floor_px),
        np.maximum(
            pnp_residual_px(left, pattern, lenses[0]), pnp_residual_px(right, pattern, lenses[1])
        ),
    )


def triangulated(u1: F64, u2: F64, P1: F64, P2: F64) -> F64:
    """(M, 3) the thesis' midpoints of undistorted pixels ``u1``, ``u2`` (M, 2)."""
    return triangulate_two_views(u1, u2, P1, P2).point_grid


def pixel_jacobian(u1: F64, u2: F64, P1: F64, P2: F64, step_px: float = 1e-3) -> F64:
    """(M, 3, 4) each midpoint's derivatives by its four pixels, by central differences."""
    M = len(u1)
    steps = np.zeros((8, M, 4))
    for k in range(4):
        steps[k, :, k], steps[4 + k, :, k] = step_px, -step_px
    a = np.concatenate([u1 + s[:, :2] for s in steps])
    b = np.concatenate([u2 + s[:, 2:] for s in steps])
    ends = triangulated(a, b, P1, P2).reshape(8, M, 3)
    return np.asarray(np.stack([(ends[k] - ends[4 + k]) / (2 * step_px) for k in range(4)], -1))


def _cameras(lenses: tuple[LensModel, LensModel], R_2_to_1: F64, t_2_in_1: F64) -> tuple[F64, F64]:
    """The two cameras' projection matrices in camera 1's frame (pinhole: undistorted)."""

    def pinhole(lens: LensModel) -> F64:
        return np.array([lens.K[0, 0], lens.K[1, 1], lens.K[0, 2], lens.K[1, 2]])

    return (
        projection_matrices(pinhole(lenses[0]), np.eye(3), np.zeros(3)),
        projection_matrices(pinhole(lenses[1]), R_2_to_1, t_2_in_1),
    )


def _held_out(
    corners: BoardCorners,
    k: int,
    fold: JointFit,
    cov_extrinsic: F64,
    lenses: tuple[LensModel, LensModel],
) -> tuple[F64, F64]:
    """The held-out view ``k``'s spacing errors and their predicted 1-sigma."""
    R, t = extrinsic_of(fold.relative)
    u1, u2 = lenses[0].undistort(corners.left[k]), lenses[1].undistort(corners.right[k])
    P1, P2 = _cameras(lenses, R, t)
    points = triangulated(u1, u2, P1, P2)
    square = float(np.linalg.norm(corners.pattern[1] - corners.pattern[0]))
    errors = spacings(points, corners.board) - square
    pattern = np.asarray(corners.pattern, np.float64)
    # Each coordinate's 1-sigma: the fit's RMS is a corner's distance (two coordinates).
    floor = fold.rms_px / np.sqrt(2)
    sigma_px = corner_sigma_px(floor, corners.left[k], corners.right[k], pattern, lenses)
    jac = pixel_jacobian(u1, u2, P1, P2)
    pixel = spacing_sigma(points, jac, sigma_px, corners.board)
    # The lengthening expected of the fit's typical noise; its spread from each corner's.
    bias, _ = spacing_second_order(points, jac, np.full(sigma_px.size, floor), corners.board)
    _, second = spacing_second_order(points, jac, sigma_px, corners.board)

    # The fold's extrinsic error, carried to the spacings by central differences over
    # (rotation vector, t), the rotation applied in camera 1's frame.
    def moved(step: F64) -> F64:
        cameras = _cameras(lenses, rotation_matrix(step[:3]) @ R, t + step[3:])
        return spacings(triangulated(u1, u2, *cameras), corners.board)

    scale = np.sqrt(np.clip(np.diag(cov_extrinsic), 1e-30, None)) * 1e-3
    J = central_jacobian(moved, np.zeros(6), scale)
    extrinsic = np.einsum("si,ij,sj->s", J, cov_extrinsic, J)
    return errors - bias, np.sqrt(pixel**2 + second + extrinsic)


def leave_one_out(
    corners: BoardCorners, lenses: tuple[LensModel, LensModel], fit: JointFit
) -> HoldoutCheck:
    """Hold each view out in turn (the module docstring).

    Parameters
    ----------
    corners : BoardCorners
        Every view of the fit (three at least).
    lenses : (LensModel, LensModel)
        The fixed intrinsics.
    fit : JointFit
        The fit on every view (each fold starts from it).

    Returns
    -------
    HoldoutCheck
    """
    V = corners.n_views
    if V < 3:
        raise InputValueError(f"leave-one-out needs 3 views or more, got {V}")
    errors, sigmas, deltas = [], [], []
    R0, t0 = extrinsic_of(fit.relative)
    for k in range(V):
        keep = np.arange(V) != k
        fold = fit_joint(corners.subset(keep), lenses, start=(fit.relative, fit.boards[keep]))
        e, s = _held_out(corners, k, fold, extrinsic_cov(fold), lenses)
        errors.append(e)
        sigmas.append(s)
        R, t = extrinsic_of(fold.relative)
        deltas.append(np.r_[rotation_vector(R @ R0.T), t - t0])
    # The jackknife's covariance of the relative pose, against the fit's.
    d = np.asarray(deltas)
    jack = np.sqrt((V - 1) / V * ((d - d.mean(axis=0)) ** 2).sum(axis=0))
    ratio = jack / np.sqrt(np.diag(extrinsic_cov(fit)))
    return HoldoutCheck.of(V, np.concatenate(errors), np.concatenate(sigmas), ratio)
