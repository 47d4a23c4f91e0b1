"""The pair's calibration: the relative pose of two cameras, with its covariance.

From stills of a checkerboard both cameras see, each camera's intrinsics fixed (from its
calibration file, or fitted on its own stills), :func:`fit_pair` finds camera 2's pose in
camera 1's frame, ``p1 = R_2_to_1 p2 + t_2_in_1`` (the thesis' ``p1 = R p2 + d``, with
camera 1 as the grid frame), by the joint least squares over every board pose and the
relative pose (:mod:`twopose.pair.board_fit`): the cost and so the answer of OpenCV's
``stereoCalibrate`` with ``CALIB_FIX_INTRINSIC``. Its covariance is the fit's,
``s^2 (J^T J)^-1`` with the board poses marginalised out, in the pair's parameters: the
rotation vector ``delta`` of a small rotation in camera 1's frame (``R = exp([delta]x)
R_2_to_1``), then ``t_2_in_1``. It is conditional on the intrinsics (their own error is
the intrinsics' covariance, carried beside it), and checked by leave-one-out
(:mod:`twopose.pair.holdout`): where the folds' relative poses scatter more than the fit
says (a view's corner errors are not independent of each other: the corner finder's and
the lens model's errors repeat across a view), the covariance is widened by the
jackknife's variance factor (the mean over the six parameters of the squared ratio of
the jackknife's 1-sigma to the fit's; never narrowed). On OpenCV's 13 photographs that
factor is about 4 (sigmas twice the fit's). A view that fits far worse than the others
(a misdetected or reversed corner grid) is dropped and named: first a view whose own
relative pose (from its two photographs alone) disagrees with the others'
(:func:`twopose.pair.board_fit.disagreeing_views`), then by the rule every board fit
shares (:func:`twopose.detect.checkerboard.outlier_view`). No I/O.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np

from twopose.arrays import F64, Bools
from twopose.camera.model import Intrinsics, intrinsics_sigma
from twopose.detect.checkerboard import outlier_view
from twopose.errors import InputValueError
from twopose.pair.board_fit import (
    BoardCorners,
    JointFit,
    LensModel,
    central_jacobian,
    disagreeing_views,
    extrinsic_cov,
    extrinsic_of,
    fit_joint,
    rotation_matrix,
)
from twopose.pair.holdout import HoldoutCheck, leave_one_out
from twopose.values.units import Units, unit_factor, unit_spec

__all__ = [
    "ADVISED_VIEWS",
    "MAX_RMS_PX",
    "MIN_BASELINE_IN",
    "MIN_VIEWS",
    "FloorPlane",
    "PairCalibration",
    "fit_pair",
    "typed_pose_cov",
    "widening",
]

#: The fewest views of the board a pair's calibration takes: leave-one-out needs three.
MIN_VIEWS = 3
#: The views advised (the docs: ten to twenty moments); below, ``calibrate-pair`` says what
#: its sigmas leave out (on 3-4 of OpenCV's stills the pose lay 4-14 of them off: r7 K7).
ADVISED_VIEWS = 10
#: Two cameras whose centres are closer than this share of the board's square share a
#: centre: no baseline, nothing to triangulate (the same camera's stills given twice).
MIN_BASELINE_SQUARES = 0.05
#: Nor may any pair's centres be closer than 1 mm, in inches (what a pair file may state:
#: :mod:`twopose.pair.pair_file`; a fine board's 0.05 squares would be less).
MIN_BASELINE_IN = 1 / 25.4
#: Two views whose corners are within this many pixels on average, in both cameras, are
#: one still given twice.
SAME_VIEW_PX = 0.5
#: A view whose own relative pose (both cameras' single-view board poses) is further than
#: this from the others' is dropped before the fit, named: its corners run backwards in one
#: camera, or the board moved between the two photographs. The single views' own scatter
#: on OpenCV's photographs is a fraction of a degree and a few percent of the baseline.
MAX_VIEW_DEG = 5.0
MAX_VIEW_SHIFT = 0.25
#: A fit whose RMS reprojection error (pixels) is above this is refused: a board's corners
#: are found to a few tenths of a pixel (OpenCV's own pairs fit at 0.45 px), so a larger
#: misfit means stills of different moments, a wrong board size or wrong intrinsics, whose
#: pose no leave-one-out check can vouch for (its sigmas grow with the misfit).
MAX_RMS_PX = 2.0


@dataclass(frozen=True, kw_only=True, eq=False)
class FloorPlane:
    """The floor in camera 1's frame: ``normal . p = height``.

    ``normal`` (3,) unit, from camera 1 toward the floor; ``height`` camera 1's centre's
    distance to the floor (> 0, the pair's units); ``cov`` (4, 4) the covariance of
    ``(normal, height)`` (rank 3: the normal stays unit).
    """

    normal: F64
    height: float
    cov: F64

    def __post_init__(self) -> None:
        """Check a unit normal, a positive height and a symmetric 4x4 covariance."""
        n = np.asarray(self.normal, dtype=np.float64).reshape(-1)
        cov = np.asarray(self.cov, dtype=np.float64)
        if n.shape != (3,) or not np.isfinite(n).all() or abs(np.linalg.norm(n) - 1) > 1e-6:
            raise InputValueError(f"the floor's normal must be a unit 3-vector, got {n}")
        if not (np.isfinite(self.height) and self.height > 0):
            raise InputValueError(
                f"the floor's height must be a positive length, got {self.height}"
            )
        _check_cov(cov, 4, "the floor's covariance")
        object.__setattr__(self, "normal", n)
        object.__setattr__(self, "height", float(self.height))
        object.__setattr__(self, "cov", cov)

    @property
    def ground(self) -> tuple[F64, float]:
        """The floor as the solvers take a ground plane: ``(normal, offset)``."""
        return self.normal, self.height

    @property
    def sigma_height(self) -> float:
        """The height's 1-sigma (the pair's units)."""
        return float(np.sqrt(max(self.cov[3, 3], 0.0)))

    @property
    def sigma_tilt_deg(self) -> float:
        """The normal's 1-sigma tilt (degrees; the root of its covariance's trace)."""
        return float(np.degrees(np.sqrt(max(np.trace(self.cov[:3, :3]), 0.0))))

    def scaled(self, factor: float) -> FloorPlane:
        """The same floor with lengths times ``factor`` (a change of units)."""
        s = np.diag([1.0, 1.0, 1.0, factor])
        return FloorPlane(normal=self.normal, height=self.height * factor, cov=s @ self.cov @ s)


@dataclass(frozen=True, kw_only=True, eq=False)
class PairCalibration:
    """Two cameras fixed to each other: intrinsics, relative pose, its covariance, the floor.

    ``R_2_to_1`` (3, 3) and ``t_2_in_1`` (3,, the pair's ``units``): camera 2's axes and
    centre in camera 1's frame, ``p1 = R_2_to_1 p2 + t_2_in_1``. ``cov_extrinsic`` (6, 6):
    the covariance of (rotation vector in camera 1's frame, rad; ``t_2_in_1``). ``rms_px``
    the fit's RMS (OpenCV's: root mean square corner distance), ``n_views`` its views;
    ``sigma1``/``sigma2`` each camera's intrinsics' 1-sigma (empty: unknown);
    ``intrinsics_from`` how the intrinsics were had; ``check`` the leave-one-out check.
    """

    intrinsics1: Intrinsics
    intrinsics2: Intrinsics
    R_2_to_1: F64
    t_2_in_1: F64
    cov_extrinsic: F64
    rms_px: float
    n_views: int
    units: Units
    floor: FloorPlane | None = None
    sigma1: Mapping[str, float] = field(default_factory=dict)
    sigma2: Mapping[str, float] = field(default_factory=dict)
    intrinsics_from: str = ""
    view_names: tuple[str, ...] = ()
    view_rms_px: tuple[float, ...] = ()
    dropped: tuple[str, ...] = ()
    check: HoldoutCheck | None = None
    #: The variance factor ``cov_extrinsic`` holds over the fit's own (>= 1: the
    #: leave-one-out's jackknife widened it; 1: not widened, or no check).
    cov_factor: float = 1.0

    def __post_init__(self) -> None:
        """Check the shapes, a rotation, a finite centre, a covariance, the units."""
        R = np.asarray(self.R_2_to_1, dtype=np.float64)
        t = np.asarray(self.t_2_in_1, dtype=np.float64).reshape(-1)
        if R.shape != (3, 3) or not np.isfinite(R).all():
            raise InputValueError(f"R_2_to_1 must be a 3x3 rotation, got {R.tolist()}")
        if np.abs(R.T @ R - np.eye(3)).max() > 1e-6 or np.linalg.det(R) < 0:
            raise InputValueError(
                "R_2_to_1 is not a rotation (R^T R = I, det R = 1 to 1e-6): "
                f"{np.round(R, 9).tolist()}"
            )
        if t.shape != (3,) or not np.isfinite(t).all():
            raise InputValueError(f"t_2_in_1 must be three finite numbers, got {t.tolist()}")
        cov = np.asarray(self.cov_extrinsic, dtype=np.float64)
        _check_cov(cov, 6, "cov_extrinsic")
        if not (np.isfinite(self.cov_factor) and self.cov_factor >= 1):
            raise InputValueError(f"cov_factor must be a number >= 1, got {self.cov_factor}")
        if not (np.isfinite(self.rms_px) and self.rms_px >= 0):
            raise InputValueError(f"rms_px must be a length in pixels >= 0, got {self.rms_px}")
        object.__setattr__(self, "units", unit_spec(self.units).units)
        object.__setattr__(self, "R_2_to_1", R)
        object.__setattr__(self, "t_2_in_1", t)
        object.__setattr__(self, "cov_extrinsic", cov)
        object.__setattr__(self, "sigma1", intrinsics_sigma(self.sigma1))
        object.__setattr__(self, "sigma2", intrinsics_sigma(self.sigma2))

    def behind(self, points: F64) -> Bools:
        """(P,) whether each (P, 3) point (camera 1's frame) lies behind either camera.

        Method 2's planes can meet their plane behind the cameras (the finger pointing
        away from where they look, or the cameras given in the wrong order: a new user's
        r7 K11, drawn `ok` 142 in behind camera 1); a one-camera trial's typed poses are
        then what its tests blame, a pair has none.
        """
        p = np.nan_to_num(np.asarray(points, dtype=np.float64))
        in_2 = (p - self.t_2_in_1) @ self.R_2_to_1  # R^T (p - t), row by row
        return np.asarray((p[:, 2] <= 0) | (in_2[:, 2] <= 0))

    @property
    def angles_deg(self) -> F64:
        """``R_2_to_1`` as the typed angles (rx, ry, rz) in degrees, ``R = Rx Ry Rz``."""
        from twopose.rig.constants import angles_deg_from_rotation

        return angles_deg_from_rotation(self.R_2_to_1)

    @property
    def baseline(self) -> float:
        """The distance between the cameras' centres (the pair's units)."""
        return float(np.linalg.norm(self.t_2_in_1))

    @property
    def sigma_angles_deg(self) -> F64:
        """(3,) the 1-sigma of :attr:`angles_deg` (degrees)."""
        return np.sqrt(np.diag(typed_pose_cov(self))[3:])

    @property
    def sigma_t(self) -> F64:
        """(3,) the 1-sigma of ``t_2_in_1`` (the pair's units)."""
        return np.sqrt(np.diag(self.cov_extrinsic)[3:])

    def in_units(self, units: Units) -> PairCalibration:
        """The same calibration with its lengths in ``units``."""
        f = unit_factor(self.units, units)
        s = np.diag([1.0, 1.0, 1.0, f, f, f])
        return dataclasses.replace(
            self,
            t_2_in_1=self.t_2_in_1 * f,
            cov_extrinsic=s @ self.cov_extrinsic @ s,
            floor=None if self.floor is None else self.floor.scaled(f),
            units=unit_spec(units).units,
            check=None if self.check is None else self.check.scaled(f),
        )


def _check_cov(cov: F64, n: int, what: str) -> None:
    """A symmetric, positive semi-definite ``n`` x ``n`` covariance, or refused in words."""
    if cov.shape != (n, n) or not np.isfinite(cov).all():
        raise InputValueError(f"{what} must be a {n}x{n} matrix of finite numbers")
    scale = max(float(np.abs(cov).max()), 1e-300)
    if np.abs(cov - cov.T).max() > 1e-9 * scale:
        raise InputValueError(f"{what} must be symmetric")
    if np.linalg.eigvalsh(cov).min() < -1e-9 * scale:
        raise InputValueError(f"{what} must be positive semi-definite (a covariance)")


def typed_pose_cov(pair: PairCalibration, step: float = 1e-7) -> F64:
    """(6, 6) the covariance of camera 2's pose as a typed pose: (t, angles in degrees).

    In the layout of :data:`twopose.uncertainty.propagate.INPUTS_PER_VIEW`'s pose (tx, ty, tz, rx,
    ry, rz), so that the solvers' propagation carries the pair's extrinsic error as it
    carries a typed pose's: the angles' derivatives by the rotation vector by central
    differences.
    """
    from twopose.rig.constants import angles_deg_from_rotation

    A = central_jacobian(
        lambda d: angles_deg_from_rotation(rotation_matrix(d) @ pair.R_2_to_1), np.zeros(3), step
    )
    G = np.zeros((6, 6))
    G[:3, 3:] = np.eye(3)  # t from the pair's second block
    G[3:, :3] = A
    return np.asarray(G @ pair.cov_extrinsic @ G.T)


def fit_pair(
    corners: BoardCorners,
    intrinsics: tuple[Intrinsics, Intrinsics],
    *,
    units: Units,
    names: Sequence[str] = (),
    sigmas: tuple[Mapping[str, float], Mapping[str, float]] = ({}, {}),
    intrinsics_from: str = "",
    check: bool = True,
) -> PairCalibration:
    """The pair's relative pose from views of a board both cameras see (module docstring).

    Parameters
    ----------
    corners : BoardCorners
        Each view's corners in camera 1 and camera 2 (:func:`twopose.detect.checkerboard.
        find_board`) and the board's geometry: ``BoardCorners.of(board, square, left,
        right)``, the square in ``units``.
    intrinsics : (Intrinsics, Intrinsics)
        Camera 1's and camera 2's, held fixed.
    units : Units
        The unit of the board's square and so of ``t_2_in_1``.
    names : sequence of str
        Each view's name (its files), for the messages; default ``view 1`` ...
    sigmas : (mapping, mapping)
        Each camera's intrinsics' 1-sigma, carried into the calibration.
    intrinsics_from : str
        How the intrinsics were had, in words (kept in the pair file).
    check : bool
        Whether to run the leave-one-out check (:mod:`twopose.pair.holdout`) and widen
        the covariance by it.

    Returns
    -------
    PairCalibration
        Without a floor (:func:`twopose.pair.floor.floor_from_board` adds it).

    Raises
    ------
    InputValueError
        Fewer than :data:`MIN_VIEWS` views (after dropping outliers), one still given twice,
        cameras that share a centre, a fit that does not fix the poses, corners outside
        the intrinsics' image, an RMS above :data:`MAX_RMS_PX`.
    """
    units = unit_spec(units).units
    square = float(np.linalg.norm(corners.pattern[1] - corners.pattern[0]))
    labels = list(names) if names else [f"view {k + 1}" for k in range(corners.n_views)]
    if len(labels) != corners.n_views:
        raise InputValueError(f"{len(labels)} names for {corners.n_views} views")
    _check_views(corners, labels, intrinsics)
    lenses = (LensModel.of(intrinsics[0]), LensModel.of(intrinsics[1]))
    fit, corners, labels, dropped = _fit_without_outliers(corners, labels, lenses)
    if fit.rms_px > MAX_RMS_PX:
        raise InputValueError(
            f"the fit's RMS reprojection error is {fit.rms_px:.1f} px over {corners.n_views} "
            f"views, above the {MAX_RMS_PX:g} px a board's corners allow: are the two cameras' "
            "stills of the same moments, the board's size --board's, the intrinsics these "
            "cameras'?"
        )
    R, t = extrinsic_of(fit.relative)
    least = max(MIN_BASELINE_SQUARES * square, MIN_BASELINE_IN / unit_spec(units).inches)
    if np.linalg.norm(t) < least:
        raise InputValueError(
            f"the two cameras share a centre (baseline {np.linalg.norm(t):.3g} {units}): are "
            "the left and right stills the same camera's?"
        )
    checked = leave_one_out(corners, lenses, fit) if check else None
    factor = 1.0 if checked is None else widening(checked)
    return PairCalibration(
        intrinsics1=intrinsics[0],
        intrinsics2=intrinsics[1],
        R_2_to_1=R,
        t_2_in_1=t,
        cov_extrinsic=extrinsic_cov(fit) * factor,
        rms_px=fit.rms_px,
        n_views=corners.n_views,
        units=units,
        sigma1=sigmas[0],
        sigma2=sigmas[1],
        intrinsics_from=intrinsics_from,
        view_names=tuple(labels),
        view_rms_px=tuple(float(e) for e in fit.view_rms_px),
        dropped=tuple(dropped),
        check=checked,
        cov_factor=factor,
    )


def _fit_without_outliers(
    corners: BoardCorners, labels: list[str], lenses: tuple[LensModel, LensModel]
) -> tuple[JointFit, BoardCorners, list[str], list[str]]:
    """The joint fit, the views kept and their names, and the views dropped, each with why.

    First the views whose own relative pose disagrees with the others', then, fit after
    fit, the worst view while it is an outlier, never below :data:`MIN_VIEWS` views.
    """

    def kept(keep: Bools) -> tuple[BoardCorners, list[str]]:
        return corners.subset(keep), [n for n, k in zip(labels, keep, strict=True) if k]

    dropped: list[str] = []
    far = disagreeing_views(corners, lenses, max_deg=MAX_VIEW_DEG, max_share=MAX_VIEW_SHIFT)
    if far and corners.n_views - len(far) >= MIN_VIEWS:
        dropped += [f"{labels[k]} ({why})" for k, why in far]
        keep = np.ones(corners.n_views, dtype=bool)
        keep[[k for k, _ in far]] = False
        corners, labels = kept(keep)
    fit = fit_joint(corners, lenses)
    while corners.n_views > MIN_VIEWS and (worst := outlier_view(fit.view_rms_px)) is not None:
        dropped.append(f"{labels[worst]} (RMS {fit.view_rms_px[worst]:.2f} px)")
        keep = np.arange(corners.n_views) != worst
        corners, labels = kept(keep)
        fit = fit_joint(corners, lenses, start=(fit.relative, fit.boards[keep]))
    return fit, corners, labels, dropped


def widening(check: HoldoutCheck) -> float:
    """The variance factor the jackknife asks of the fit's covariance (>= 1).

    The mean over the six parameters of (jackknife 1-sigma / fit 1-sigma)^2: one factor
    for the whole covariance, so its shape (the fit's correlations) is kept.
    """
    ratio = np.asarray(check.jackknife_ratio, dtype=np.float64)
    ratio = ratio[np.isfinite(ratio)]
    return max(1.0, float(np.mean(ratio**2))) if ratio.size else 1.0


def _check_views(
    corners: BoardCorners, labels: list[str], intrinsics: tuple[Intrinsics, Intrinsics]
) -> None:
    """Enough views, none given twice, every corner inside its camera's image."""
    if corners.n_views < MIN_VIEWS:
        raise InputValueError(
            f"the board was seen by both cameras in {corners.n_views} view(s); the pair's "
            f"calibration needs {MIN_VIEWS} or more (and its check leaves one out): show the "
            "board to both cameras at several places and tilts"
        )
    for camera, pixels, cam in (("camera 1", corners.left, intrinsics[0]),
                                ("camera 2", corners.right, intrinsics[1])):  # fmt: skip
        outside = ((pixels < 0) | (pixels > [cam.width, cam.height])).any(axis=(1, 2))
        if outside.any():
            k = int(np.argmax(outside))
            raise InputValueError(
                f"{labels[k]}: {camera}'s corners lie outside its {cam.width}x{cam.height} "
                "image: are the intrinsics this camera's (its calibration file), at this size?"
            )
    moved = np.linalg.norm(corners.left[:, None] - corners.left[None], axis=-1).mean(axis=-1)
    moved += np.linalg.norm(corners.right[:, None] - corners.right[None], axis=-1).mean(axis=-1)
    same = np.argwhere(np.triu(moved < 2 * SAME_VIEW_PX, k=1))
    if same.size:
        a, b = same[0]
        raise InputValueError(
            f"{labels[a]} and {labels[b]} show the board at the same place in both cameras "
            "(one still given twice?): each view must show the board anew"
        )
