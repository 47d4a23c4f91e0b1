"""Estimation: each trial's pose measurements in, its estimates and their uncertainty out.

Every trial's usable poses become one row of a padded batch, so each estimator runs once
per session, vectorized over trials (:func:`twopose.session_estimate.estimate_session`
drives it); the same batch, perturbed,
propagates the input covariance to every estimate (:mod:`twopose.uncertainty`): pixels,
typed poses and, where the camera's calibration recorded its 1-sigma, the intrinsics.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from twopose.arrays import F64
from twopose.camera import Intrinsics, rotation_from_angles_deg
from twopose.conditioning import parallax_sine
from twopose.errors import InputValueError
from twopose.format.entries import PoseEntry
from twopose.frames import PoseMeasurement, combine_frames
from twopose.margins import (  # the options' one home, light for the CLI
    DEFAULT_MIN_GROUND_ANGLE_DEG,
    DEFAULT_MIN_PARALLAX_DEG,
    DEFAULT_MIN_PLANE_ANGLE_DEG,
    EstimateOptions,
)
from twopose.methods import Method, Solver, spec_of
from twopose.misclosure import PLANES, RAYS, MisclosureModel
from twopose.planes import GROUND_PLANE, ConstraintPlane
from twopose.solve import (
    NViewLines,
    image_lines,
    projection_matrices,
    triangulate_ground,
    triangulate_lines,
    triangulate_points,
)
from twopose.uncertainty import (
    INPUTS_PER_VIEW,
    SHARED_INPUTS,
    Shared,
    frame_scatter,
    measurement_covariance,
)

__all__ = [
    "DEFAULT_MIN_GROUND_ANGLE_DEG",
    "DEFAULT_MIN_PARALLAX_DEG",
    "DEFAULT_MIN_PLANE_ANGLE_DEG",
    "EstimateOptions",
    "GroundSpec",
    "PoseView",
    "ViewBatch",
    "measure",
    "pose_view",
    "scatter_of",
    "scatters_of",
    "solve_batch",
]


#: The ground plane as ``(normal_grid (3,), offset)``.
GroundSpec = tuple[F64, float]


@dataclass(frozen=True, kw_only=True)
class PoseView:
    """One complete pose of a trial: its camera, typed pose and per-frame detections."""

    pose: int
    intrinsics: F64  # (4,) fx, fy, cx, cy
    width_height: tuple[int, int]
    t_grid: F64  # (3,) typed camera centre
    r_deg: F64  # (3,) typed angles, R_cam_to_grid = Rx Ry Rz
    t_sigma: float  # 1-sigma of each typed translation component (session units)
    r_sigma_deg: float  # 1-sigma of each typed angle
    centroids: F64  # (K, 2)
    thetas: F64  # (K,)
    found: NDArray[np.bool_]  # (K,)
    camera_id: str = ""  # views of one camera share its intrinsics' error
    # (4,) the calibration's 1-sigma of fx, fy, cx, cy (0: taken as exact)
    intrinsics_sigma: F64 = field(default_factory=lambda: np.zeros(len(SHARED_INPUTS)))


def pose_view(
    entry: PoseEntry,
    intrinsics: Intrinsics,
    found: Sequence[bool],
    centroids_px: Sequence[tuple[float, float]],
    thetas_deg: Sequence[float],
    intrinsics_sigma: Mapping[str, float] | None = None,
) -> PoseView:
    """A complete pose: its typed pose, its camera and its frames' detections as arrays.

    ``intrinsics_sigma`` is the camera's calibration 1-sigma (``Camera.intrinsics_sigma``):
    of its keys, fx, fy, cx and cy enter the uncertainty. The distortion's are left out:
    the solvers use the pinhole model on the detected pixels (nothing is undistorted), so
    the estimate does not depend on k1..k3, p1, p2.
    """
    sigma = intrinsics_sigma or {}
    return PoseView(
        pose=entry.pose,
        intrinsics=np.array([intrinsics.fx, intrinsics.fy, intrinsics.cx, intrinsics.cy]),
        width_height=(intrinsics.width, intrinsics.height),
        t_grid=np.array(entry.t_grid),
        r_deg=np.array(entry.r_deg),
        t_sigma=entry.translation_resolution,
        r_sigma_deg=entry.rotation_resolution_deg,
        centroids=np.array(centroids_px, dtype=np.float64).reshape(-1, 2),
        thetas=np.array(thetas_deg, dtype=np.float64),
        found=np.array(found, dtype=bool),
        camera_id=entry.camera_id,
        intrinsics_sigma=np.array([float(sigma.get(k, 0.0)) for k in SHARED_INPUTS]),
    )


def measure(
    views: list[list[PoseView]], options: EstimateOptions
) -> tuple[list[list[PoseMeasurement]], NDArray[np.bool_], NDArray[np.bool_]]:
    """Each pose's frames combined into one measurement.

    The thesis' mean, or median / robust. Returns the measurements (empty for a trial with fewer
    than two poses), and per trial whether it is complete and whether every pose was detected.
    """
    complete = np.array([len(v) >= 2 for v in views], dtype=bool)
    # A view met again (guidance's candidates share the trial's views) is combined once:
    # the same object, the same frames, during this call.
    combined: dict[int, PoseMeasurement] = {}

    def combine(v: PoseView) -> PoseMeasurement:
        if id(v) not in combined:
            combined[id(v)] = combine_frames(v.centroids, v.thetas, v.found, options.combine)
        return combined[id(v)]

    measurements = [
        [combine(v) for v in row] if ok else [] for row, ok in zip(views, complete, strict=True)
    ]
    detected = np.array(
        [ok and all(m.found for m in ms) for ms, ok in zip(measurements, complete, strict=True)],
        dtype=bool,
    )
    return measurements, complete, detected


@dataclass(frozen=True, kw_only=True)
class ViewBatch:
    """Rows of N >= 2 pose measurements as arrays, padded to the longest row."""

    inputs: F64  # (T, N, 9) in the uncertainty.INPUTS_PER_VIEW layout
    intrinsics: F64  # (T, N, 4); padding views get (1, 1, 0, 0): P = [I | 0]
    valid: NDArray[np.bool_]  # (T, N)

    @classmethod
    def of(
        cls, measurements: list[list[PoseMeasurement]], views: list[list[PoseView]]
    ) -> ViewBatch:
        """The padded batch of a session's trials, from their measurements and views."""
        T = len(measurements)
        N = max(len(row) for row in measurements)
        x = np.zeros((T, N, len(INPUTS_PER_VIEW)))
        x[..., :3] = np.nan
        intr = np.tile([1.0, 1.0, 0.0, 0.0], (T, N, 1))
        valid = np.zeros((T, N), dtype=bool)
        for i, (row, row_views) in enumerate(zip(measurements, views, strict=True)):
            for j, (m, v) in enumerate(zip(row, row_views, strict=True)):
                x[i, j] = [*m.centroid_px, m.theta_deg, *v.t_grid, *v.r_deg]
                intr[i, j], valid[i, j] = v.intrinsics, True
        return cls(inputs=x, intrinsics=intr, valid=valid)

    def rows(self, which: NDArray[np.bool_] | NDArray[np.int_]) -> ViewBatch:
        """The batch of some of its trials (a boolean mask or indices over T)."""
        return ViewBatch(
            inputs=self.inputs[which], intrinsics=self.intrinsics[which], valid=self.valid[which]
        )

    def P(self, inputs: F64 | None = None) -> F64:
        """Projection matrices (T, N, 3, 4) of these (or perturbed) inputs."""
        x = self.inputs if inputs is None else inputs
        R = rotation_from_angles_deg(x[..., 6:9])
        return projection_matrices(self.intrinsics, R, x[..., 3:6])


@dataclass(frozen=True, kw_only=True)
class Solved:
    """Every estimator's answer for a batch of trials."""

    point: F64  # (T, 3)
    direction: F64 | None  # (T, 3), lines only
    optimal: F64 | None  # (T, 3), points only: the reprojection-optimal estimate
    conditioning: F64
    status: NDArray[np.str_]
    reason: NDArray[np.str_]
    margins: dict[str, F64] = field(default_factory=dict)  # degrees, by column name


def solve_batch(
    method: Method, batch: ViewBatch, ground: GroundSpec | None, options: EstimateOptions
) -> Solved:
    """Batch-solve rows of N >= 2 pose measurements with every estimator."""
    return _solver_of(method).solve(batch, ground, options.min_conditioning)


def _solver_of(method: Method) -> _SolverEntry:
    """What solves ``method``'s measurements: its spec's :attr:`~MethodSpec.solver`."""
    solver = spec_of(method).solver
    entry = _SOLVERS.get(solver) if solver is not None else None
    if entry is None:
        raise InputValueError(f"{method} sessions reconstruct nothing (the rig's calibration)")
    return entry


def _solve_points(batch: ViewBatch, _ground: GroundSpec | None, mc: float) -> Solved:
    """Method 1: the thesis' two-ray least squares and the reprojection-optimal point."""
    px, valid, P = batch.inputs[..., :2], batch.valid, batch.P()
    s = triangulate_points(px, P, valid=valid, min_conditioning=mc)
    o = triangulate_points(px, P, valid=valid, estimator="optimal", min_conditioning=mc)
    margins = {"parallax_deg": degrees_from_sine(s.conditioning)}
    return Solved(
        point=s.point_grid,
        direction=None,
        optimal=o.point_grid,
        conditioning=s.conditioning,
        status=s.status,
        reason=s.reason,
        margins=margins,
    )


def _view_planes(batch: ViewBatch, mc: float) -> tuple[F64, F64, NViewLines, dict[str, F64]]:
    """The image lines, cameras and the planes' line (and its margins) of line and ground."""
    px, th, valid, P = batch.inputs[..., :2], batch.inputs[..., 2], batch.valid, batch.P()
    lines = image_lines(px, th)
    ls = triangulate_lines(lines, P, valid=valid, min_conditioning=mc)
    margins = {
        "parallax_deg": degrees_from_sine(parallax_sine(P, valid, ls.point_grid)),
        "plane_angle_deg": degrees_from_sine(ls.conditioning),
    }
    return lines, P, ls, margins


def _solve_lines(batch: ViewBatch, _ground: GroundSpec | None, mc: float) -> Solved:
    """The fixed line: the views' planes' intersection."""
    _, _, ls, margins = _view_planes(batch, mc)
    return Solved(
        point=ls.point_grid,
        direction=ls.direction_grid,
        optimal=None,
        conditioning=ls.conditioning,
        status=ls.status,
        reason=ls.reason,
        margins=margins,
    )


def _solve_ground(batch: ViewBatch, ground: GroundSpec | None, mc: float) -> Solved:
    """Method 2: the views' planes and the ground plane y = h."""
    assert ground is not None
    lines, P, ls, margins = _view_planes(batch, mc)
    g = triangulate_ground(lines, P, ground[0], ground[1], valid=batch.valid, min_conditioning=mc)
    margins["parallax_deg"] = degrees_from_sine(parallax_sine(P, batch.valid, g.point_grid))
    n3 = ground[0] / np.linalg.norm(ground[0])
    margins["line_plane_angle_deg"] = degrees_from_sine(np.abs(ls.direction_grid @ n3))
    return Solved(
        point=g.point_grid,
        direction=None,
        optimal=None,
        conditioning=g.conditioning,
        status=g.status,
        reason=g.reason,
        margins=margins,
    )


def _thesis_point(
    x: F64, P: F64, valid: NDArray[np.bool_], _ground: GroundSpec | None, mc: float, _ref: F64
) -> F64:
    """Method 1's thesis estimate of perturbed inputs: the dot's rays."""
    return triangulate_points(x[..., :2], P, valid=valid, min_conditioning=mc).point_grid


def _thesis_line(
    x: F64, P: F64, valid: NDArray[np.bool_], _ground: GroundSpec | None, mc: float, ref: F64
) -> F64:
    """The fixed line's thesis estimate of perturbed inputs: its point nearest ``ref``."""
    lines = image_lines(x[..., :2], x[..., 2])
    ls = triangulate_lines(lines, P, valid=valid, min_conditioning=mc)
    return nearest_on_line(ls.point_grid, ls.direction_grid, ref)


def _thesis_ground(
    x: F64, P: F64, valid: NDArray[np.bool_], ground: GroundSpec | None, mc: float, _ref: F64
) -> F64:
    """Method 2's thesis estimate of perturbed inputs: the planes and the ground."""
    assert ground is not None
    lines = image_lines(x[..., :2], x[..., 2])
    return triangulate_ground(
        lines, P, ground[0], ground[1], valid=valid, min_conditioning=mc
    ).point_grid


@dataclass(frozen=True, kw_only=True)
class _SolverEntry:
    """What one solver does (a method's spec names it: :data:`twopose.methods.Solver`)."""

    #: Every estimator's answer for a batch: (batch, ground, min_conditioning).
    solve: Callable[[ViewBatch, GroundSpec | None, float], Solved]
    #: The thesis' estimate of perturbed inputs, for propagation: (inputs, cameras, valid
    #: views, ground, min_conditioning, reference point (a line reports its point nearest it)).
    thesis: Callable[[F64, F64, NDArray[np.bool_], GroundSpec | None, float, F64], F64]
    #: What its estimate predicts of each view, for the misclosure (:mod:`twopose.misclosure`):
    #: method 2's misclosure is its planes' line's (the ground adds no redundancy).
    misclosure: MisclosureModel


#: The solvers, by the name a method's spec gives (:attr:`MethodSpec.solver`).
_SOLVERS: Mapping[Solver, _SolverEntry] = {
    "rays": _SolverEntry(solve=_solve_points, thesis=_thesis_point, misclosure=RAYS),
    "planes": _SolverEntry(solve=_solve_lines, thesis=_thesis_line, misclosure=PLANES),
    "planes and ground": _SolverEntry(
        solve=_solve_ground, thesis=_thesis_ground, misclosure=PLANES
    ),
}


def _perturbed_views(batch: ViewBatch, x: F64) -> tuple[int, NDArray[np.bool_], F64]:
    """The views of perturbed inputs ``x``, for propagation.

    How many copies of the batch's T trials ``x`` stacks, their valid views, and each
    view's projection matrix from the (perturbed) inputs.
    """
    reps = x.shape[0] // batch.valid.shape[0]  # propagate stacks copies of the T trials
    valid = np.tile(batch.valid, (reps, 1))
    R = rotation_from_angles_deg(x[..., 6:9])
    # With the intrinsics' uncertainty (twopose.uncertainty.Shared) they follow the view's
    # inputs; otherwise they are the batch's, exact.
    D = len(INPUTS_PER_VIEW)
    intr = x[..., D:] if x.shape[-1] > D else np.tile(batch.intrinsics, (reps, 1, 1))
    return reps, valid, projection_matrices(intr, R, x[..., 3:6])


def thesis_estimate(
    method: Method,
    batch: ViewBatch,
    ground: GroundSpec | None,
    options: EstimateOptions,
    reference: F64,
) -> Callable[[F64], F64]:
    """The thesis' estimate as a function of the (perturbed) inputs, for propagation.

    Lines report their point nearest ``reference`` (T, 3), held fixed.
    """
    mc = options.min_conditioning
    thesis = _solver_of(method).thesis

    def estimate(x: F64) -> F64:
        reps, valid, P = _perturbed_views(batch, x)
        return thesis(x, P, valid, ground, mc, np.tile(reference, (reps, 1)))

    return estimate


def misclosure_residuals(method: Method, batch: ViewBatch) -> tuple[Callable[[F64], F64], int]:
    """Each view's residuals as a function of the (perturbed) inputs, and the parameters.

    The residuals (R T, N, 2) of the method's solver's :class:`MisclosureModel`, for
    :func:`twopose.misclosure.misclosures`; the estimate's parameter count beside them.
    """
    model = _solver_of(method).misclosure

    def residuals(x: F64) -> F64:
        _, valid, P = _perturbed_views(batch, x)
        return model.residuals(x, P, valid)

    return residuals, model.parameters


def thesis_direction(
    batch: ViewBatch, options: EstimateOptions, reference: F64
) -> Callable[[F64], F64]:
    """A line's unit direction as a function of the (perturbed) inputs, for propagation.

    The thesis' line (two planes, eq. 3.17), its sign that of ``reference`` (T, 3), so a
    perturbation never flips it.
    """
    mc = options.min_conditioning

    def direction(x: F64) -> F64:
        reps, valid, P = _perturbed_views(batch, x)
        lines = image_lines(x[..., :2], x[..., 2])
        d = triangulate_lines(lines, P, valid=valid, min_conditioning=mc).direction_grid
        sign = np.sign(np.einsum("ti,ti->t", d, np.tile(reference, (reps, 1))))
        return np.asarray(d * np.where(sign == 0, 1.0, sign)[:, None])

    return direction


def nearest_on_line(point: F64, direction: F64, reference: F64) -> F64:
    """(T, 3) the point of each line nearest its reference point."""
    s = np.einsum("ti,ti->t", reference - point, direction)
    return np.asarray(point + s[:, None] * direction)


def degrees_from_sine(sine: F64) -> F64:
    """An angle in degrees from its sine (NaN stays NaN)."""
    with np.errstate(invalid="ignore"):
        return np.asarray(np.degrees(np.arcsin(np.clip(sine, 0.0, 1.0))))


def margin_warnings(
    status: NDArray[np.str_],
    margins: dict[str, F64],
    options: EstimateOptions,
    plane: ConstraintPlane = GROUND_PLANE,
) -> list[str]:
    """Per trial, the margins under their thresholds (empty when none, or not ok).

    The planes' line's angle to ``plane``, the method's, is named by it ("line-ground
    angle").
    """
    limits = {
        "parallax_deg": ("ray parallax", options.min_parallax_deg),
        "plane_angle_deg": ("plane angle", options.min_plane_angle_deg),
        "line_plane_angle_deg": (f"line-{plane.noun} angle", options.min_ground_angle_deg),
    }
    out = []
    for i in range(len(status)):
        notes = [
            f"{label} {margins[key][i]:.2f} deg < {limit:g}"
            for key, (label, limit) in limits.items()
            if key in margins and status[i] == "ok" and margins[key][i] < limit
        ]
        out.append("; ".join(notes))
    return out


# --------------------------------------------------------------------------- input covariance


def scatter_of(view: PoseView, m: PoseMeasurement) -> tuple[F64, int]:
    """A pose's frame scatter over the frames its measurement used, and its dof."""
    used = view.found.copy()
    used[list(m.rejected)] = False
    return frame_scatter(view.centroids, view.thetas, used)


def scatters_of(
    views: list[list[PoseView]], measurements: list[list[PoseMeasurement]]
) -> list[list[tuple[F64, int]]]:
    """Each pose's :func:`scatter_of`, a view met again (the same objects) computed once."""
    known: dict[tuple[int, int], tuple[F64, int]] = {}

    def one(v: PoseView, m: PoseMeasurement) -> tuple[F64, int]:
        key = (id(v), id(m))
        if key not in known:
            known[key] = scatter_of(v, m)
        return known[key]

    return [
        [one(v, m) for v, m in zip(vs, ms, strict=False)]
        for vs, ms in zip(views, measurements, strict=True)
    ]


def input_covariance(
    measurements: list[list[PoseMeasurement]],
    views: list[list[PoseView]],
    scatters: list[list[tuple[F64, int]]],
    pooled: F64,
    batch: ViewBatch,
    *,
    median: bool,
    floor: tuple[float, float] = (0.0, 0.0),
    t_sigma: float | None = None,
) -> F64:
    """Each view's input covariance (T, N, 9, 9): pixels and typed pose.

    (T, N, 9, 9): each view's pixel covariance from its frame scatter and the detector's
    ``floor`` (:func:`~twopose.uncertainty.measurement_covariance`), and its typed pose's
    1-sigma resolutions on the diagonal (padding views: zero). ``t_sigma``: a measured
    placing sigma (session units) in place of each pose's typed resolution.
    """
    T, N, D = batch.inputs.shape
    C = np.zeros((T, N, D, D))
    blocks: dict[tuple[int, int], F64] = {}  # a view met again (the same objects): once
    for i, (row, row_views, row_scatter) in enumerate(
        zip(measurements, views, scatters, strict=True)
    ):
        for j, (m, v, (S, dof)) in enumerate(zip(row, row_views, row_scatter, strict=True)):
            key = (id(v), id(m))
            if key not in blocks:
                block = np.zeros((D, D))
                block[:3, :3] = measurement_covariance(
                    S, dof, pooled, m.n_used, median=median, floor=floor
                )
                block[3:6, 3:6] = np.eye(3) * (v.t_sigma if t_sigma is None else t_sigma) ** 2
                block[6:9, 6:9] = np.eye(3) * v.r_sigma_deg**2
                blocks[key] = block
            C[i, j] = blocks[key]
    return C


def shared_intrinsics(views: list[list[PoseView]], batch: ViewBatch) -> Shared | None:
    """The intrinsics as inputs shared by each trial's views of one camera.

    Each comes with its calibration's covariance (diagonal: the calibration records 1-sigma per
    intrinsic); None when no view's camera has a sigma, so such sessions propagate as
    before.
    """
    if not any(v.intrinsics_sigma.any() for row in views for v in row):
        return None
    T, N = batch.valid.shape
    group = np.full((T, N), -1)
    sigmas: list[list[F64]] = []
    for i, row in enumerate(views):
        cameras: list[str] = []
        sigmas.append([])
        for j, v in enumerate(row):
            if v.camera_id not in cameras:
                cameras.append(v.camera_id)
                sigmas[i].append(v.intrinsics_sigma)
            group[i, j] = cameras.index(v.camera_id)
    G, S = max(len(row) for row in sigmas), len(SHARED_INPUTS)
    cov = np.zeros((T, G, S, S))
    for i, row_sigma in enumerate(sigmas):
        for g, sigma in enumerate(row_sigma):
            cov[i, g] = np.diag(sigma**2)
    return Shared(values=batch.intrinsics.copy(), group=group, cov=cov)


def across_line_sigma_px(theta_deg: F64, input_cov: F64) -> F64:
    """(T, N) 1-sigma pixel error across each view's image line, from its covariance."""
    t = np.deg2rad(theta_deg)
    n = np.stack([-np.sin(t), np.cos(t)], axis=-1)
    var = np.einsum("tni,tnij,tnj->tn", n, input_cov[..., :2, :2], n)
    return np.asarray(np.sqrt(np.where(np.isfinite(var) & (var > 0), var, 1.0)))
