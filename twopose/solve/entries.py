"""The solvers' entries: each kind of reconstruction, solved for a batch of trials.

Every trial's usable poses are one row of a padded :class:`ViewBatch`; a
:class:`SolverEntry` solves it with every estimator (:attr:`SolverEntry.solve`), gives the
thesis' estimate of perturbed inputs for the propagation of the uncertainty
(:attr:`SolverEntry.thesis`), what its estimate predicts of each view for the misclosure
(:attr:`SolverEntry.misclosure`) and ``twopose-analyze solve``'s answer
(:attr:`SolverEntry.answer`). A method's spec holds its solver
(:attr:`twopose.methods.specs.MethodSpec.solver`), so that all four read the same entry:
:data:`RAYS` (method 1), :data:`PLANES` (the fixed line), :data:`PLANES_AND_PLANE`
(method 2), or an extension's own.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import NDArray

from twopose.arrays import F64
from twopose.camera.model import rotation_from_angles_deg
from twopose.detect.frames import PoseMeasurement
from twopose.methods.planes import ConstraintPlane
from twopose.solve.hand_check import Answer, line_answer, plane_answer, point_answer
from twopose.solve.nview import (
    NViewLines,
    degrees_from_sine,
    image_lines,
    parallax_sine,
    projection_matrices,
    triangulate_ground,
    triangulate_lines,
    triangulate_points,
)
from twopose.uncertainty.misclosure_models import PLANES as PLANE_MISCLOSURE
from twopose.uncertainty.misclosure_models import RAYS as RAY_MISCLOSURE
from twopose.uncertainty.misclosure_models import MisclosureModel
from twopose.uncertainty.propagate import INPUTS_PER_VIEW, SHARED_INPUTS

__all__ = [
    "PLANES",
    "PLANES_AND_PLANE",
    "RAYS",
    "GroundSpec",
    "PoseView",
    "Solved",
    "SolverEntry",
    "ViewBatch",
    "degrees_from_sine",
    "nearest_on_line",
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


def nearest_on_line(point: F64, direction: F64, reference: F64) -> F64:
    """(T, 3) the point of each line nearest its reference point."""
    s = np.einsum("ti,ti->t", reference - point, direction)
    return np.asarray(point + s[:, None] * direction)


@dataclass(frozen=True, kw_only=True)
class SolverEntry:
    """What one solver does (a method's spec holds it: :class:`twopose.methods.specs.Solver`)."""

    #: Every estimator's answer for a batch: (batch, plane (``(normal, offset)``: the
    #: method's, or None), min_conditioning).
    solve: Callable[[ViewBatch, GroundSpec | None, float], Solved]
    #: The thesis' estimate of perturbed inputs, for propagation: (inputs, cameras, valid
    #: views, plane, min_conditioning, reference point (a line reports its point nearest it)).
    thesis: Callable[[F64, F64, NDArray[np.bool_], GroundSpec | None, float, F64], F64]
    #: What its estimate predicts of each view, for the misclosure
    #: (:mod:`twopose.uncertainty.misclosure`):
    #: method 2's misclosure is its planes' line's (the plane adds no redundancy).
    misclosure: MisclosureModel
    #: ``twopose-analyze solve``'s answer (:mod:`twopose.solve.hand_check`): (the request, its
    #: views, their cameras (1, N, 3, 4), the estimator, the method's plane) -> the answer.
    answer: Callable[[Any, list[Any], F64, str, ConstraintPlane | None], Answer]


#: Method 1's solver: the rays through each view's dot (thesis eq. 3.9).
RAYS = SolverEntry(
    solve=_solve_points, thesis=_thesis_point, misclosure=RAY_MISCLOSURE, answer=point_answer
)
#: The fixed line's: the planes of each view's image line and their line (eq. 3.17).
PLANES = SolverEntry(
    solve=_solve_lines, thesis=_thesis_line, misclosure=PLANE_MISCLOSURE, answer=line_answer
)
#: Method 2's: the planes' line cut by the method's plane (the ground y = h, eq. 19).
PLANES_AND_PLANE = SolverEntry(
    solve=_solve_ground, thesis=_thesis_ground, misclosure=PLANE_MISCLOSURE, answer=plane_answer
)
