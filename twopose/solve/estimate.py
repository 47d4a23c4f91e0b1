"""Estimation: each trial's pose measurements in, its estimates and their uncertainty out.

Every trial's usable poses become one row of a padded batch, so each estimator runs once
per session, vectorized over trials (:func:`twopose.solve.session.estimate_session`
drives it); the same batch, perturbed,
propagates the input covariance to every estimate (:mod:`twopose.uncertainty.propagate`): pixels,
typed poses and, where the camera's calibration recorded its 1-sigma, the intrinsics.
"""

from __future__ import annotations

from collections.abc import Callable, Mapping, Sequence

import numpy as np
from numpy.typing import NDArray

from twopose.arrays import F64
from twopose.camera.model import Intrinsics, rotation_from_angles_deg
from twopose.detect.frames import PoseMeasurement, combine_frames
from twopose.errors import InputValueError
from twopose.format.entries import PoseEntry
from twopose.methods.planes import GROUND_PLANE, ConstraintPlane
from twopose.methods.specs import Method
from twopose.solve.entries import (  # the batch and the solvers' entries (their one home)
    GroundSpec,
    PoseView,
    Solved,
    SolverEntry,
    ViewBatch,
    degrees_from_sine,
    nearest_on_line,
)
from twopose.solve.margins import (  # the options' one home, light for the CLI
    DEFAULT_MIN_GROUND_ANGLE_DEG,
    DEFAULT_MIN_PARALLAX_DEG,
    DEFAULT_MIN_PLANE_ANGLE_DEG,
    EstimateOptions,
)
from twopose.solve.nview import image_lines, projection_matrices, triangulate_lines
from twopose.uncertainty.misclosure_models import TrialConditions
from twopose.uncertainty.propagate import (
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
    "Solved",
    "ViewBatch",
    "degrees_from_sine",
    "measure",
    "misclosure_residuals",
    "nearest_on_line",
    "pose_view",
    "scatter_of",
    "scatters_of",
    "solve_batch",
    "thesis_estimate",
]


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


def solve_batch(
    method: Method, batch: ViewBatch, ground: GroundSpec | None, options: EstimateOptions
) -> Solved:
    """Batch-solve rows of N >= 2 pose measurements with every estimator.

    ``ground``: the method's plane as ``(normal, offset)``, for a method on one.
    """
    return _solver_of(method).solve(batch, ground, options.min_conditioning)


def _solver_of(method: Method) -> SolverEntry:
    """What solves ``method``'s measurements: its spec's solver's entry.

    The one entry the estimation, the propagation, the misclosure and ``solve`` read
    (:attr:`twopose.methods.specs.MethodSpec.solver`).
    """
    solver = method.spec.solver
    if solver is None:
        raise InputValueError(f"{method} sessions reconstruct nothing (the rig's calibration)")
    return solver.load()


def _perturbed_views(batch: ViewBatch, x: F64) -> tuple[int, NDArray[np.bool_], F64]:
    """The views of perturbed inputs ``x``, for propagation.

    How many copies of the batch's T trials ``x`` stacks, their valid views, and each
    view's projection matrix from the (perturbed) inputs.
    """
    reps = x.shape[0] // batch.valid.shape[0]  # propagate stacks copies of the T trials
    valid = np.tile(batch.valid, (reps, 1))
    R = rotation_from_angles_deg(x[..., 6:9])
    # With the intrinsics' uncertainty (twopose.uncertainty.propagate.Shared) they follow the view's
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


def misclosure_residuals(method: Method, batch: ViewBatch) -> tuple[TrialConditions, int]:
    """The views' condition equations with the estimate's parameters explicit, and their count.

    The method's solver's :class:`~twopose.uncertainty.misclosure.MisclosureModel` bound to
    the batch's views (each view's residuals (R T, N, 2) as a function of the (perturbed)
    inputs and the estimate's parameters, and the method's own estimate to start from), for
    :func:`twopose.uncertainty.misclosure.misclosures`.
    """
    model = _solver_of(method).misclosure

    def conditions(x: F64, theta: F64) -> F64:
        _, valid, P = _perturbed_views(batch, x)
        # theta: the batch's (T rows, tiled as the inputs are) or one per row already
        return model.conditions(x, np.tile(theta, (x.shape[0] // len(theta), 1)), P, valid)

    def estimate(x: F64) -> F64:
        _, valid, P = _perturbed_views(batch, x)
        return model.estimate(x, P, valid)

    bound = TrialConditions(
        conditions=conditions, estimate=estimate, moved=model.moved, parameters=model.parameters
    )
    return bound, model.parameters


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
    ``floor`` (:func:`~twopose.uncertainty.propagate.measurement_covariance`), and its typed pose's
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
