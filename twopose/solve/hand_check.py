"""One measurement given by hand: its views read from JSON, and each solver's answer.

The thesis GUI's "Calculate point", as ``twopose-analyze solve`` takes it. The views of its
request (:mod:`analysis.tools.solve_request` gives its fields): each view's camera (``K`` and
``pose``, or ``P``) and what it measured (``px``, or a ``line``); each solver's entry
(:class:`twopose.solve.entries.SolverEntry`) answers from them with its ``answer``
(:func:`point_answer`, :func:`line_answer`, :func:`plane_answer`), so a method's ``solve``
reads the solver its estimation does. A malformed field raises
:class:`~twopose.errors.InputValueError` naming it.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from twopose.camera.model import rotation_from_angles_deg
from twopose.errors import InputValueError
from twopose.methods.planes import ConstraintPlane
from twopose.solve.nview import (
    image_lines,
    projection_matrices,
    segment_lines,
    triangulate_ground,
    triangulate_lines,
    triangulate_points,
)
from twopose.solve.optimal_lines import centroid_segments, optimal_lines
from twopose.values.checks import numbers
from twopose.values.jsonsafe import finite_or_none

__all__ = ["Answer", "field_of", "line_answer", "plane_answer", "point_answer", "projection"]

#: An answer's fields: its point or line, then its status, reason and conditioning.
Answer = dict[str, Any]


#: No pixel, focal length, translation or matrix entry of a real camera comes near this
#: (in any unit): beyond it a number is a mistake, and the solvers' products would overflow.
_LARGEST = 1e12


def _numbers(value: Any, n: int, where: str) -> list[float]:
    if not isinstance(value, list):  # JSON arrays only: a string or object is a mistake
        raise InputValueError(f"{where} must be a list of {n} numbers, got {value!r}")
    got = list(numbers(value, n, where))
    if any(abs(v) > _LARGEST for v in got):
        raise InputValueError(
            f"{where}: {', '.join(f'{v:g}' for v in got)} lies beyond any camera or grid "
            f"(|value| <= {_LARGEST:g}): check the request"
        )
    return got


def field_of(obj: Any, key: str, where: str) -> Any:
    """``obj[key]`` of a JSON object, or an error naming ``where`` needs it."""
    if not isinstance(obj, dict) or key not in obj:
        raise InputValueError(f"{where} needs a {key!r} field")
    return obj[key]


def projection(view: Any, where: str) -> np.ndarray:
    """A view's 3x4 projection matrix: given as ``P``, or built from ``K`` and ``pose``."""
    if isinstance(view, dict) and "P" in view:
        rows = view["P"]
        if not isinstance(rows, list) or len(rows) != 3:
            raise InputValueError(f"{where}.P must be 3 rows of 4 numbers")
        P = np.array([_numbers(r, 4, f"{where}.P") for r in rows])
        if abs(np.linalg.det(P[:, :3])) < 1e-12:
            raise InputValueError(f"{where}.P has a singular left 3x3 block: not a camera")
        return P
    k = _numbers(field_of(view, "K", where), 4, f"{where}.K")
    if k[0] <= 0 or k[1] <= 0:
        raise InputValueError(f"{where}.K: fx and fy must be > 0, got {k[:2]}")
    pose = field_of(view, "pose", where)
    t = _numbers(field_of(pose, "t", f"{where}.pose"), 3, f"{where}.pose.t")
    r_deg = pose.get("r_deg", [0.0, 0.0, 0.0]) if isinstance(pose, dict) else None
    R = rotation_from_angles_deg(_numbers(r_deg, 3, f"{where}.pose.r_deg"))
    return projection_matrices(np.array(k), R, np.array(t))


def _image_line(view: Any, where: str) -> np.ndarray:
    line = field_of(view, "line", where)
    if isinstance(line, dict) and "segment_px" in line:
        return segment_lines(np.array(_numbers(line["segment_px"], 4, f"{where}.line.segment_px")))
    px = _numbers(field_of(line, "px", f"{where}.line"), 2, f"{where}.line.px")
    theta = _numbers([field_of(line, "theta_deg", f"{where}.line")], 1, f"{where}.line.theta_deg")[
        0
    ]
    return image_lines(np.array(px), theta)


def _segment(view: Any, sigma_px: float, where: str) -> tuple[np.ndarray, float]:
    """A view's measured segment and its endpoints' 1-sigma.

    A ``px``/``theta_deg`` view as the segment equivalent to its ``sigma_px`` and
    ``sigma_theta_deg``.
    """
    line = field_of(view, "line", where)
    if isinstance(line, dict) and "segment_px" in line:
        return np.array(_numbers(line["segment_px"], 4, f"{where}.line.segment_px")), sigma_px
    px = _numbers(field_of(line, "px", f"{where}.line"), 2, f"{where}.line.px")
    theta = _numbers([field_of(line, "theta_deg", f"{where}.line")], 1, f"{where}.line.theta_deg")[
        0
    ]
    sigma_theta = _numbers([view.get("sigma_theta_deg", 1.0)], 1, f"{where}.sigma_theta_deg")[0]
    if sigma_theta <= 0:
        raise InputValueError(f"{where}.sigma_theta_deg must be > 0, got {sigma_theta}")
    segment, sigma = centroid_segments(np.array(px), theta, sigma_px, sigma_theta)
    return segment, float(sigma)


def _optimal_line(views: list[Any], P: np.ndarray, sigma: list[float]) -> Answer:
    """The reprojection-optimal line's answer, its status, reason and conditioning."""
    pairs = [
        _segment(v, s, f"views[{i}]") for i, (v, s) in enumerate(zip(views, sigma, strict=True))
    ]
    ls = optimal_lines(
        np.stack([seg for seg, _ in pairs])[None], P, sigma_px=[[s for _, s in pairs]]
    )
    return {
        "line": {"point": _vec(ls.point_grid[0]), "direction": _vec(ls.direction_grid[0])},
        "reprojection_rms_px": _num(ls.rms_px[0]),
        "cov_point": _matrix(ls.cov[0, :3, :3]),
        "cov_direction": _matrix(ls.cov[0, 3:, 3:]),
        **_outcome(ls),
    }


def _outcome(result: Any) -> dict[str, Any]:
    """A solver's one result's status, reason and conditioning."""
    return {
        "status": str(result.status[0]),
        "reason": str(result.reason[0]),
        "conditioning": _num(float(result.conditioning[0])),
    }


def point_answer(
    _request: Any, views: list[Any], P: np.ndarray, estimator: str, _plane: ConstraintPlane | None
) -> Answer:
    """Method 1's: the rays through each view's pixel (``P``: (1, N, 3, 4))."""
    px = np.array(
        [
            [
                _numbers(field_of(v, "px", f"views[{i}]"), 2, f"views[{i}].px")
                for i, v in enumerate(views)
            ]
        ]
    )
    s = triangulate_points(px, P, estimator=estimator)
    return {"point": _vec(s.point_grid[0]), "reprojection_rms_px": _num(s.rms_px[0]), **_outcome(s)}


def line_answer(
    _request: Any, views: list[Any], P: np.ndarray, estimator: str, _plane: ConstraintPlane | None
) -> Answer:
    """The fixed line's: the views' planes' line (weighted by each view's ``sigma_px``)."""
    sigma = [
        _numbers([v.get("sigma_px", 1.0)], 1, f"views[{i}].sigma_px")[0]
        for i, v in enumerate(views)
    ]
    if min(sigma) <= 0:
        raise InputValueError(f"sigma_px must be > 0, got {sigma}")
    if estimator == "optimal":
        return _optimal_line(views, P, sigma)
    lines = np.stack([_image_line(v, f"views[{i}]") for i, v in enumerate(views)])[None]
    ls = triangulate_lines(lines, P, estimator=estimator, sigma_px=[sigma])
    line = {"point": _vec(ls.point_grid[0]), "direction": _vec(ls.direction_grid[0])}
    return {"line": line, **_outcome(ls)}


def plane_answer(
    request: Any, views: list[Any], P: np.ndarray, _estimator: str, plane: ConstraintPlane | None
) -> Answer:
    """Method 2's: the views' planes and the method's plane.

    The ground ``y = ground_y``; another plane's offset under its key
    (:attr:`twopose.methods.planes.ConstraintPlane.request_key`).
    """
    if plane is None:
        raise InputValueError("a point on a plane needs the method's plane")
    key = plane.request_key or plane.setup_key
    lines = np.stack([_image_line(v, f"views[{i}]") for i, v in enumerate(views)])[None]
    c = _numbers([field_of(request, key, f"a request on {plane.name}")], 1, key)[0]
    g = triangulate_ground(lines, P, *plane.plane(c))
    return {"point": _vec(g.point_grid[0]), **_outcome(g)}


def _num(v: float) -> float | None:
    return finite_or_none(float(v))


def _vec(v: np.ndarray) -> list[float] | None:
    return None if not np.isfinite(v).all() else [float(x) for x in v]


def _matrix(m: np.ndarray) -> list[list[float]] | None:
    return None if not np.isfinite(m).all() else [[float(x) for x in row] for row in m]
