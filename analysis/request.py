"""The hand-check request of ``twopose-analyze solve``: JSON in, JSON out (the thesis GUI's
"Calculate point").

Request::

    {"views": [{"K": [fx, fy, cx, cy],
                "pose": {"t": [x, y, z], "r_deg": [rx, ry, rz]},
                "px": [col, row]},                       # point, or for line/ground:
               {..., "line": {"px": [col, row], "theta_deg": t}}],
     "ground_y": h}                                      # ground only

``pose.t`` is the camera centre in the grid frame, ``R = Rx Ry Rz`` (camera -> grid).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from analysis.solve import solve_ground, solve_line, solve_point
from recorder.camera import rotation_from_angles_deg
from recorder.errors import InputValueError

__all__ = ["solve_request"]


def _numbers(value: Any, n: int, where: str) -> list[float]:
    if not isinstance(value, list) or len(value) != n:
        raise InputValueError(f"{where} must be a list of {n} numbers, got {value!r}")
    out = []
    for v in value:
        if isinstance(v, bool) or not isinstance(v, int | float) or not math.isfinite(v):
            raise InputValueError(f"{where} must hold finite numbers, got {value!r}")
        out.append(float(v))
    return out


def _field(obj: Any, key: str, where: str) -> Any:
    if not isinstance(obj, dict) or key not in obj:
        raise InputValueError(f"{where} needs a {key!r} field")
    return obj[key]


def solve_request(method: str, request: Any) -> dict[str, Any]:
    """Validate a request, solve it, and return the JSON-ready answer."""
    views = _field(request, "views", "the request")
    if not isinstance(views, list) or len(views) != 2:
        n = len(views) if isinstance(views, list) else "no"
        raise InputValueError(
            f"the request has {n} views; this version solves exactly 2 "
            "(more views come with n-pose support)"
        )
    K, R, t, px, theta = [], [], [], [], []
    for i, v in enumerate(views):
        where = f"views[{i}]"
        k = _numbers(_field(v, "K", where), 4, f"{where}.K")
        if k[0] <= 0 or k[1] <= 0:
            raise InputValueError(f"{where}.K: fx and fy must be > 0, got {k[:2]}")
        pose = _field(v, "pose", where)
        t.append(_numbers(_field(pose, "t", f"{where}.pose"), 3, f"{where}.pose.t"))
        r_deg = pose.get("r_deg", [0.0, 0.0, 0.0]) if isinstance(pose, dict) else None
        R.append(rotation_from_angles_deg(_numbers(r_deg, 3, f"{where}.pose.r_deg")))
        K.append(k)
        if method == "point":
            px.append(_numbers(_field(v, "px", where), 2, f"{where}.px"))
        else:
            line = _field(v, "line", where)
            px.append(_numbers(_field(line, "px", f"{where}.line"), 2, f"{where}.line.px"))
            theta.append(
                _numbers(
                    [_field(line, "theta_deg", f"{where}.line")], 1, f"{where}.line.theta_deg"
                )[0]
            )
    args = (np.array([px]), np.array([K]), np.array([R]), np.array([t]))
    if method == "point":
        s = solve_point(*args)
        answer: dict[str, Any] = {"point": _vec(s.point_grid[0])}
        status, reason, cond = s.status[0], s.reason[0], s.conditioning[0]
    elif method == "line":
        ls = solve_line(args[0], np.array([theta]), *args[1:])
        answer = {
            "line": {"point": _vec(ls.point_grid[0]), "direction": _vec(ls.direction_grid[0])}
        }
        status, reason, cond = ls.status[0], ls.reason[0], ls.conditioning[0]
    elif method == "ground":
        h = _numbers([_field(request, "ground_y", "a ground request")], 1, "ground_y")[0]
        g = solve_ground(args[0], np.array([theta]), *args[1:], [0.0, 1.0, 0.0], h)
        answer = {"point": _vec(g.point_grid[0])}
        status, reason, cond = g.status[0], g.reason[0], g.conditioning[0]
    else:
        raise InputValueError(f"method must be point, line or ground, got {method!r}")
    answer |= {"status": str(status), "reason": str(reason), "conditioning": _num(cond)}
    return answer


def _num(v: float) -> float | None:
    return None if not math.isfinite(v) else float(v)


def _vec(v: np.ndarray) -> list[float] | None:
    return None if not np.isfinite(v).all() else [float(x) for x in v]
