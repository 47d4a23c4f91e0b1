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
(``warnings``), never reported silently as if the data had decided it.

The operator's **placing error** (issue 46): each capture's camera position, known from
the corners to a fraction of a millimetre, differs from its typed pose by where the laptop
really was. The fit carries it as three parameters per capture with a Gaussian prior of
sigma ``s``, and ``s`` is itself estimated, a variance component: each round refits with
the current ``s`` and sets it by EM on the fit's linearization (:mod:`twopose.rig.placing`,
the marginal likelihood's maximum; the constants integrated out under their priors, so a
shift common to all captures goes to the camera offset and the tape's scale, not to the
placing). Its 1-sigma is from that likelihood's Fisher information. The model is the
recorder's and the analysis': one sigma on each of x, y and z (a laptop on a table has
its y fixed by the table, yet the placing y of the simulator and of a tilted or shimmed
laptop is not zero, and the corners see it). Each capture's **rotation error** is carried
too (issue 54), three angles with the typed rotation resolution as their prior: a laptop
turned by a tenth of a degree moves a board's image as a sideways placing error does, and
unmodelled it was read as one. A turn shows beside a shift only in the board's
perspective, where the corner detector errs too: each capture also carries two
perspective-shaped corner errors (:func:`perspective_modes`), so that the detector's
error there is not read as a turn and then as placing, nor, where no capture is turned,
as the mount's rotation, which every capture shares; an unturned capture carries a
roll-shaped one too (:func:`roll_mode`; a turned capture's own roll has that shape). A
placing sigma the captures cannot measure (the fit's floor) is only bounded, and said
(``BoardRigFit.placing.upper_bound``). The constants' covariance is kept whole
(``RigConstants.covariance``): the rig file carries it. No I/O.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.optimize import OptimizeResult, least_squares

from twopose.arrays import F64
from twopose.errors import InputValueError
from twopose.rig.constants import (
    RIG_PARAMETERS,
    RIG_PRIORS,
    RigConstants,
    RigCovariance,
    against_priors,
    prior_sigma,
)
from twopose.rig.file import PLACING_LIMIT_IN
from twopose.rig.placing import PLACING_FLOOR_IN, Linearized, placing_em, placing_upper_bound
from twopose.uncertainty.noise import MIN_PLACING_DOF, PlacingSigma
from twopose.values.units import DEFAULT_UNITS, Units, unit_spec

__all__ = [
    "PERSPECTIVE_PRIOR",
    "RIG_PRIORS",
    "ROLL_PRIOR",
    "BoardRigFit",
    "board_order",
    "check_identifiable",
    "fit_board_rig",
    "perspective_modes",
    "roll_mode",
]

#: The constants a board determines (RIG_PARAMETERS order, without the ground's).
FITTED = tuple(g for g in RIG_PARAMETERS if g != "ground_height_error")
FITTED_NAMES = tuple(n for g in FITTED for n in RIG_PARAMETERS[g])
#: Two typed moves are parallel when the smaller singular value of the moves is under this
#: fraction of the larger.
MIN_DIRECTION_RATIO = 0.2
#: Poses are at several distances when their depths spread over this fraction of the mean.
MIN_DEPTH_SPREAD = 0.1
#: The placing sigma's estimate is refitted at most this many times (it settles in 3-5).
MAX_ROUNDS = 10
#: A capture typed with a rotation resolution at or under this (degrees) has no rotation
#: error fitted: typed exactly (a simulated session records 1e-9).
ROTATION_FLOOR_DEG = 1e-6
#: The prior 1-sigma of each turned capture's two perspective-shaped corner errors
#: (:func:`perspective_modes`), in the capture's corner sigmas at its outermost corner. On
#: 15 rendered boards turned 0.2 degrees (typed honestly) the placing sigma read a median
#: +13%, (estimate - truth) / sigma RMS 1.45 without them; +7% and 1.25 at 3, +6.5% and 1.15
#: at 10, which costs a fifth of the degrees of freedom (30 at 3, 26 at 10, of 33).
PERSPECTIVE_PRIOR = 3.0
#: The prior 1-sigma of an unturned capture's roll-shaped corner error (:func:`roll_mode`),
#: in corner sigmas at its outermost corner: on 10 rendered boards, against the poses they
#: were rendered from (``/simulation/truth``), 0.9-1.1 RMS about no mean (docs/rig.md).
ROLL_PRIOR = 1.0
_MODES = 3  # a capture's shaped corner errors: two perspective patterns, then the roll's


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
    #: The operator's placing sigma the captures measured (None: typed exactly, or not
    #: measured), and the degrees of freedom its 1-sigma is from.
    placing: PlacingSigma | None = None
    placing_dof: float = 0.0


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


def _project(constants: F64, corners: F64, t: F64, r_deg: F64, intrinsics: F64) -> F64:
    """The corners' pixels (C, K, 2) predicted for the 10 ``constants`` (FITTED order).

    ``t`` and ``r_deg`` (C, 3): where each capture's camera was really placed and turned
    (the typed pose plus its placing and rotation errors); ``corners`` (C, K, 3) and
    ``intrinsics`` (C, 4) per capture.
    """
    rig = RigConstants.from_vector(np.append(constants, 0.0))
    t_true, R = rig.true_poses(t, r_deg)
    k = rig.true_intrinsics(intrinsics)[:, None, :]  # (C, 1, 4)
    p_cam = np.einsum("cji,ckj->cki", R, corners - t_true[:, None])  # R^T (X - t)
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


def fit_board_rig(  # noqa: PLR0913 - the captures' arrays, then how to fit them
    corners_grid: ArrayLike,
    observed_px: ArrayLike,
    t_typed: ArrayLike,
    r_typed_deg: ArrayLike,
    intrinsics: ArrayLike,
    *,
    units: Units = DEFAULT_UNITS,
    t_sigma: float = 0.0,
    r_sigma_deg: ArrayLike = 0.0,
    groups: Sequence[str] = FITTED,
    measure_placing: bool = True,
) -> BoardRigFit:
    """The rig's constants from board captures, and the operator's placing sigma.

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
        placing): each capture's placing error is fitted with it as its starting prior, so
        the constants' sigma includes what the poses' placing leaves unknown (0: typed
        exactly, no placing error fitted nor measured).
    r_sigma_deg : float or (C,) array_like
        The typed angles' 1-sigma (the entries' rotation resolution), for all or per
        capture: each capture's rotation error is fitted with it as its prior (known, not
        estimated), so that a turned laptop is not read as a misplaced one (0: typed
        exactly).
    groups : sequence of str
        The constants' groups to fit (:data:`FITTED`, the default, or some of them); the
        rest stay nominal, with sigma NaN.
    measure_placing : bool
        Estimate the placing sigma itself (:mod:`twopose.rig.placing`) and fit with it
        (``BoardRigFit.placing``); False keeps ``t_sigma`` as a fixed prior.
    """
    t, r, u, X, k, r_sigma = _captures(
        corners_grid, observed_px, t_typed, r_typed_deg, intrinsics, r_sigma_deg
    )
    free = _free_mask(groups)
    check_identifiable(t, X[:, :, 2].mean(axis=1))
    model = _Model.of(free, units, t_sigma, r_sigma)
    modes = np.concatenate([perspective_modes(u, k), roll_mode(u, k)[:, None]], axis=1)

    def predicted(x: F64, sigma_px: F64) -> F64:
        """The corners predicted, the detector's perspective-shaped error added."""
        constants, placed, turned, shaped = model.split(x)
        mode: F64 = np.einsum("cm,cmkj->ckj", shaped, modes) * sigma_px[:, None, None]
        return _project(constants, X, t + placed, r + turned, k) + mode

    def residuals(p: F64, sigma_px: F64, s: float) -> F64:
        corners = ((predicted(model.full(p), sigma_px) - u) / sigma_px[:, None, None]).ravel()
        return np.concatenate([corners, (p - model.nominal) / model.prior(s)])

    def solve(p: F64, sigma_px: F64, s: float) -> OptimizeResult:
        # MINPACK's Levenberg-Marquardt: its QR is its own, so a dense problem of a hundred
        # parameters costs the same whatever the machine's BLAS threads are doing.
        return least_squares(residuals, p, args=(sigma_px, s), x_scale=model.prior(s), method="lm")

    measuring = measure_placing and model.n_placed > 0
    floor = PLACING_FLOOR_IN / unit_spec(units).inches
    sigma_px, s, p, dof = np.ones(len(t)), float(t_sigma), model.nominal, 0.0
    lin: Linearized | None = None
    for round_ in range(MAX_ROUNDS):
        # Each capture's corner noise from the previous fit's residuals (a far board's
        # corners are less precise than a near one's: one noise for all would let the far
        # captures' errors read as placing), the placing sigma by EM on the fit's
        # linearization; refitted until both settle.
        fit = solve(p, sigma_px, s)
        p = fit.x
        corner_res = predicted(model.full(p), sigma_px) - u
        new_px = np.maximum(np.sqrt(np.mean(corner_res**2, axis=(1, 2))), 1e-6)
        new_s = s
        if measuring:
            rows = np.repeat(sigma_px / new_px, corner_res[0].size)[:, None]
            jac = np.asarray(fit.jac)[: corner_res.size] * rows
            lin = model.linearized(jac, (corner_res / new_px[:, None, None]).ravel(), p)
            new_s, dof = placing_em(lin, s, floor)
        settled = (
            np.all(np.abs(new_px / sigma_px - 1) < 0.01) and abs(new_s / s - 1 if s else 0) < 0.01
        )
        sigma_px, s = new_px, new_s
        if round_ >= 2 and settled:
            break
    fit = solve(p, sigma_px, s)
    cov = _covariance(fit.jac, free)
    sigma = np.append(np.sqrt(np.clip(np.diag(cov), 0.0, None)), np.nan)
    x = model.full(fit.x)
    constants = x[: len(FITTED_NAMES)]
    names = _names(free)
    rig = dataclasses.replace(
        RigConstants.from_vector(np.append(constants, 0.0), units),
        covariance=RigCovariance.of(names, cov[np.ix_(free, free)]) if names else None,
    )
    placing: PlacingSigma | None = None
    warned: tuple[str, ...] = ()
    if measuring and lin is not None:
        placing, warned = _measured(lin, s, dof, floor, units, len(t))
    delta = np.append(constants, 0.0) - RigConstants().vector()
    return BoardRigFit(
        rig=rig,
        sigma=sigma,
        cov=cov,
        rms_px=float(np.sqrt(np.mean((predicted(x, sigma_px) - u) ** 2))),
        n_captures=len(t),
        n_corners=u.shape[0] * u.shape[1],
        free=names,
        warnings=against_priors(delta, units, names) + warned,
        placing=placing,
        placing_dof=dof,
    )


def _captures(
    corners_grid: ArrayLike,
    observed_px: ArrayLike,
    t_typed: ArrayLike,
    r_typed_deg: ArrayLike,
    intrinsics: ArrayLike,
    r_sigma_deg: ArrayLike,
) -> tuple[F64, F64, F64, F64, F64, F64]:
    """:func:`fit_board_rig`'s arrays, checked, one row per capture.

    The typed centres and angles, the observed corners, the corners' grid, the intrinsics
    and the rotation resolutions.
    """
    t, r = np.asarray(t_typed, dtype=np.float64), np.asarray(r_typed_deg, dtype=np.float64)
    u = np.asarray(observed_px, dtype=np.float64)
    n_corners = np.shape(corners_grid)[-2] if np.ndim(corners_grid) >= 2 else 0
    X = _per_capture(corners_grid, len(t), (n_corners, 3), "corners_grid")
    k = _per_capture(intrinsics, len(t), (4,), "intrinsics")
    r_sigma = _per_capture(r_sigma_deg, len(t), (), "r_sigma_deg")
    if u.shape != (len(t), n_corners, 2) or r.shape != t.shape or not np.isfinite(u).all():
        raise InputValueError(
            f"board captures: want (captures, corners, 2) = ({len(t)}, {n_corners}, 2) finite "
            f"pixels, got {u.shape}"
        )
    return t, r, u, X, k, r_sigma


def _measured(
    lin: Linearized, s: float, dof: float, floor: float, units: Units, captures: int
) -> tuple[PlacingSigma, tuple[str, ...]]:
    """The placing sigma the fit measured, or its upper bound with a warning.

    At the fit's floor, or on fewer than :data:`twopose.uncertainty.noise.MIN_PLACING_DOF` degrees
    of
    freedom, the captures do not measure it: the most it can be is written instead
    (:func:`twopose.rig.placing.placing_upper_bound`), never as "measured".
    """
    inches = unit_spec(units).inches
    at_floor = s <= floor * (1 + 1e-6)
    if not at_floor and dof >= MIN_PLACING_DOF:
        sigma = PlacingSigma(
            sigma_in=s * inches,
            sigma_sigma_in=s * inches / math.sqrt(2.0 * dof),
            measured_by="the board's captures",
            captures=captures,
        )
        return sigma, ()
    limit = PLACING_LIMIT_IN / inches  # the most a rig file may record
    bound = min(placing_upper_bound(lin, s, limit), limit)
    why = (
        "the fit's floor: the captures show no placing error their corners resolve"
        if at_floor
        else f"only {dof:.1f} degrees of freedom (fewer than {MIN_PLACING_DOF})"
    )
    warning = (
        f"the placing sigma is at {why}; written as an upper bound, at most {bound:.3g} "
        f"{units} (one-sided 95%), not as measured; the regions start from each pose's typed "
        "resolution, never from the bound (a real operator's board shows a placing error: "
        "check the board session)"
    )
    bounded = PlacingSigma(
        sigma_in=bound * inches,
        measured_by="the board's captures",
        captures=captures,
        upper_bound=True,
    )
    return bounded, (warning,)


@dataclass(frozen=True, kw_only=True)
class _Model:
    """The board fit's parameters: which are fitted, their prior means and sigmas.

    The full vector is the 10 constants (FITTED order), each capture's placing error
    (C x 3), rotation error (C x 3, degrees) and shaped corner errors (C x 3, corner sigmas:
    the two of :func:`perspective_modes`, then :func:`roll_mode`); the fitted ones are the
    free constants, every placing error (when the translations have a resolution), the
    rotation errors of captures typed with a rotation resolution (over
    :data:`ROTATION_FLOOR_DEG`), every capture's perspective modes, and the roll mode of
    the captures whose rotation is not fitted (a fitted roll about the optical axis moves
    the corners in that very shape).
    """

    fitted: NDArray[np.bool_]
    full_nominal: F64
    rig_prior: F64  # the free constants' prior sigma
    rotation_prior: F64  # the fitted rotation errors' prior sigma (degrees)
    n_free: int
    n_placed: int
    n_captures: int

    @classmethod
    def of(cls, free: NDArray[np.bool_], units: Units, t_sigma: float, r_sigma: F64) -> _Model:
        """The model of ``free`` constants, ``t_sigma``'s placing, per capture ``r_sigma``."""
        C = len(r_sigma)
        n_placed = 3 * C if t_sigma > 0 else 0
        turned = r_sigma > ROTATION_FLOOR_DEG
        turning = np.repeat(turned, 3)
        shaped = np.stack([np.ones(C, bool), np.ones(C, bool), ~turned], axis=1).ravel()
        nominal = np.concatenate([RigConstants().vector()[:-1], np.zeros((6 + _MODES) * C)])
        return cls(
            fitted=np.concatenate([free, np.full(3 * C, n_placed > 0), turning, shaped]),
            full_nominal=nominal,
            rig_prior=_prior_sigma(units)[free],
            # The shaped errors' priors (in the capture's corner sigmas) after the angles'.
            rotation_prior=np.concatenate(
                [
                    np.repeat(r_sigma, 3)[turning],
                    np.tile([PERSPECTIVE_PRIOR, PERSPECTIVE_PRIOR, ROLL_PRIOR], C)[shaped],
                ]
            ),
            n_free=int(free.sum()),
            n_placed=n_placed,
            n_captures=C,
        )

    @property
    def nominal(self) -> F64:
        """The fitted parameters' prior means."""
        fitted: F64 = self.full_nominal[self.fitted]
        return fitted

    def prior(self, s: float) -> F64:
        """The fitted parameters' prior sigmas, the placing errors' ``s``."""
        return np.concatenate([self.rig_prior, np.full(self.n_placed, s), self.rotation_prior])

    def full(self, p: F64) -> F64:
        """The full vector of the fitted parameters ``p`` (the rest nominal)."""
        out = self.full_nominal.copy()
        out[self.fitted] = p
        return out

    def split(self, x: F64) -> tuple[F64, F64, F64, F64]:
        """A full vector's constants (10), placing, rotation errors and modes (C, 3/3/3)."""
        n, C = len(FITTED_NAMES), self.n_captures
        placed, turned = x[n : n + 3 * C].reshape(C, 3), x[n + 3 * C : n + 6 * C].reshape(C, 3)
        return x[:n], placed, turned, x[n + 6 * C :].reshape(C, _MODES)

    def linearized(self, jac: F64, res: F64, p: F64) -> Linearized:
        """The fit's linearization for the placing sigma (:mod:`twopose.rig.placing`)."""
        return Linearized(
            jac=jac,
            res=res,
            p=p,
            nominal=self.nominal,
            prior=self.prior,
            placing=slice(self.n_free, self.n_free + self.n_placed),
        )


def perspective_modes(observed_px: F64, intrinsics: F64) -> F64:
    """Each capture's two perspective-shaped corner patterns (C, 2, K, 2).

    In pixels per corner sigma: ``(x^2, x y)`` and ``(x y, y^2)`` in the normalised image
    (from the principal point), scaled to 1 at the capture's outermost corner.

    A camera turned by ``a`` about its y axis moves a fronto-parallel board's image as a
    sideways shift does, but for ``-a (x^2, x y)``; the first pattern is that difference
    (the second the x axis'). The corners' detector errs in these patterns too: on the
    rendered boards a far board's corners (8-pixel squares) show them at 3-6 of their own
    white-noise sigmas, which the fit read as turns of 0.3-1 degrees and then, the turns
    held to their typed resolution, as placing (issue 54: a placing sigma +48% on one seed
    of seven, (estimate - truth) / sigma RMS 1.68). Fitted with a prior of
    :data:`PERSPECTIVE_PRIOR` corner sigmas at the outermost corner, a turn is read from the
    board's perspective only beyond what the detector's own error could shape.
    """
    x = (observed_px[..., 0] - intrinsics[:, None, 2]) / intrinsics[:, None, 0]
    y = (observed_px[..., 1] - intrinsics[:, None, 3]) / intrinsics[:, None, 1]
    reach = np.max(x**2 + y**2, axis=1)[:, None]  # (C, 1)
    first = np.stack([x * x, x * y], axis=-1) / reach[..., None]
    second = np.stack([x * y, y * y], axis=-1) / reach[..., None]
    modes: F64 = np.stack([first, second], axis=1)
    return modes


def roll_mode(observed_px: F64, intrinsics: F64) -> F64:
    """Each capture's roll-shaped corner pattern (C, K, 2), in pixels per corner sigma.

    ``(-y, x)`` in the normalised image (from the principal point), scaled to 1 at the
    capture's outermost corner: how a roll about the optical axis moves the corners. The
    detector errs in this shape too (:data:`ROLL_PRIOR`); unfitted, where no turn is, that
    went to the mount's roll every capture shares (r7 H2).
    """
    x = (observed_px[..., 0] - intrinsics[:, None, 2]) / intrinsics[:, None, 0]
    y = (observed_px[..., 1] - intrinsics[:, None, 3]) / intrinsics[:, None, 1]
    reach = np.sqrt(np.max(x**2 + y**2, axis=1))[:, None, None]  # (C, 1, 1)
    mode: F64 = np.stack([-y, x], axis=-1) / reach
    return mode


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
