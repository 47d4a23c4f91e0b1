"""What a solver's estimate predicts of each view: the misclosure's condition equations.

Each model (:class:`MisclosureModel`, held by the solver table:
:class:`twopose.solve.entries.SolverEntry`) states where a trial's views agree with an estimate
``theta`` whose parameters are explicit: ``r(x, theta) = 0``, two numbers a view, linear in
the view's own pixels. A point's rays (:data:`RAYS`, ``theta`` its 3 coordinates): each
view's dot minus the point projected. A 3-D line's planes (:data:`PLANES`, 4 parameters:
``theta`` a point of the line and its direction, moved across and turned in the two
directions square to it): each view's centroid's distance across the line projected, and
its angle against it. The method's own estimate (the thesis' point or line) is where the
adjustment (:mod:`twopose.uncertainty.adjustment`) starts.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64, Bools
from twopose.detect.detection import wrap_theta_deg
from twopose.solve.nview import image_lines, triangulate_lines, triangulate_points

__all__ = [
    "PLANES",
    "RAYS",
    "Conditions",
    "MisclosureModel",
    "TrialConditions",
    "plane_conditions",
    "ray_conditions",
]

#: A model's condition equations ``r(x, theta) = 0``: each view's residuals from the
#: (perturbed) inputs ``x`` (R, N, 9[+S]), the estimate's parameters ``theta`` (R, K), the
#: cameras ``P`` (R, N, 3, 4) and valid views (R, N): (R, N, 2), zero in a padding view.
Conditions = Callable[[F64, F64, F64, Bools], F64]


@dataclass(frozen=True, kw_only=True)
class MisclosureModel:
    """What a solver's estimate predicts of each view, with its parameters explicit."""

    #: Where the views agree with an estimate ``theta``: ``conditions(x, theta) = 0``.
    conditions: Conditions
    #: The method's own estimate from the inputs (x, P, valid) -> theta (R, K): the start.
    estimate: Callable[[F64, F64, Bools], F64]
    #: ``theta`` (R, K) moved by a step (R, parameters) in its own tangent directions.
    moved: Callable[[F64, F64], F64]
    #: The estimate's degrees of freedom: a point 3, a 3-D line 4.
    parameters: int


@dataclass(frozen=True, kw_only=True)
class TrialConditions:
    """A batch's :class:`MisclosureModel` bound to its views (:func:`misclosures` takes it).

    ``conditions(x, theta)``: stacked (perturbed) inputs (R T, N, 9[+S]) and ``theta``
    (T, K) -> (R T, N, 2) as :func:`twopose.uncertainty.propagate.propagate` calls an
    estimate; ``estimate(x)``: inputs (T, N, 9[+S]) -> the method's own ``theta`` (T, K).
    """

    conditions: Callable[[F64, F64], F64]
    estimate: Callable[[F64], F64]
    moved: Callable[[F64, F64], F64]
    parameters: int


def _project(P: F64, X: F64) -> F64:
    """(R, N, 2) the points ``X`` (R, 3) (or (R, N, 3)) in each view's pixels."""
    Xh = np.concatenate([X, np.ones((*X.shape[:-1], 1))], axis=-1)
    if Xh.ndim == 2:
        Xh = np.broadcast_to(Xh[:, None], (*P.shape[:2], 4))
    h = np.einsum("rnij,rnj->rni", P, Xh)
    return np.asarray(h[..., :2] / h[..., 2:3])


def ray_conditions(x: F64, theta: F64, P: F64, valid: Bools) -> F64:
    """Each view's measured pixel minus the point ``theta`` (R, 3) projected (R, N, 2)."""
    r = x[..., :2] - _project(P, theta)
    return np.asarray(np.where(valid[..., None], r, 0.0))


def _thesis_point(x: F64, P: F64, valid: Bools) -> F64:
    """The thesis' point of the views' rays (R, 3)."""
    return triangulate_points(x[..., :2], P, valid=valid).point_grid


def _shifted(theta: F64, step: F64) -> F64:
    """The point ``theta`` (R, 3) moved by ``step`` (session units)."""
    return np.asarray(theta + step)


def plane_conditions(x: F64, theta: F64, P: F64, valid: Bools) -> F64:
    """Each view's centroid across, and angle against, the 3-D line ``theta`` projected.

    ``theta`` (R, 6): a point of the line and its unit direction. (R, N, 2): the measured
    centroid's signed distance (px) from the projected line and the measured angle minus
    the projected line's (degrees, lines have no arrow).
    """
    a = _project(P, theta[:, :3])
    b = _project(P, theta[:, :3] + theta[:, 3:])
    d = b - a
    length = np.linalg.norm(d, axis=-1, keepdims=True)
    normal = np.stack([-d[..., 1], d[..., 0]], axis=-1) / length
    across = np.einsum("rni,rni->rn", x[..., :2] - a, normal)
    angle = wrap_theta_deg(x[..., 2] - np.degrees(np.arctan2(d[..., 1], d[..., 0])))
    r = np.stack([across, angle], axis=-1)
    return np.asarray(np.where(valid[..., None], r, 0.0))


def _thesis_line(x: F64, P: F64, valid: Bools) -> F64:
    """The thesis' line of the views' planes (R, 6): its point and unit direction."""
    line = triangulate_lines(image_lines(x[..., :2], x[..., 2]), P, valid=valid)
    return np.concatenate([line.point_grid, line.direction_grid], axis=-1)


def _line_moved(theta: F64, step: F64) -> F64:
    """The line ``theta`` (R, 6) moved and turned in the two directions square to it.

    Across itself by ``step[:, :2]`` (session units), its direction by ``step[:, 2:]``
    (radians).
    """
    p, d = theta[:, :3], theta[:, 3:]
    axis = np.eye(3)[np.argmin(np.abs(np.nan_to_num(d)), axis=1)]
    e1 = np.cross(d, axis)
    e1 = e1 / np.linalg.norm(e1, axis=1, keepdims=True)
    e2 = np.cross(d, e1)
    p = p + step[:, :1] * e1 + step[:, 1:2] * e2
    d = d + step[:, 2:3] * e1 + step[:, 3:4] * e2
    return np.concatenate([p, d / np.linalg.norm(d, axis=1, keepdims=True)], axis=-1)


#: A point's rays: its projection in every view.
RAYS = MisclosureModel(
    conditions=ray_conditions, estimate=_thesis_point, moved=_shifted, parameters=3
)
#: A line's planes (the fixed line, method 2's finger): the line projected in every view.
PLANES = MisclosureModel(
    conditions=plane_conditions, estimate=_thesis_line, moved=_line_moved, parameters=4
)
