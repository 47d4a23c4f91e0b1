"""The hand-check request of ``twopose-analyze solve``: JSON in, JSON out (the thesis GUI's
"Calculate point").

Request::

    {"views": [{"K": [fx, fy, cx, cy],
                "pose": {"t": [x, y, z], "r_deg": [rx, ry, rz]},
                "px": [col, row]},                       # point, or for line/ground:
               {"P": [[...4], [...4], [...4]],           # instead of K and pose
                "line": {"px": [col, row], "theta_deg": t}},   # or {"segment_px": [x0, y0, x1, y1]}
               ...],                                     # two or more views
     "ground_y": h,                                      # ground only
     "estimator": "thesis"}                              # or "optimal" (points, lines)
                                                         # or "weighted" (lines; a view may
                                                         # give "sigma_px", default 1)

Lines with ``"optimal"``: the reprojection-optimal line (:mod:`twopose.solve.optimal_lines`),
``sigma_px`` a view's 1-sigma across the line (of each endpoint of a segment, of the point
of a ``px``/``theta_deg`` view, which may also give ``"sigma_theta_deg"``, default 1); the
answer adds ``reprojection_rms_px`` and the covariances ``cov_point`` (of the reported
point, across the line) and ``cov_direction`` (of the unit direction).

``pose.t`` is the camera centre in the grid frame, ``R = Rx Ry Rz`` (camera -> grid). Each
method's answer is its solver's (:attr:`twopose.methods.specs.MethodSpec.solver`: the entry its
estimation reads, :mod:`twopose.solve.hand_check`), so a registered method solves as it analyses.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from twopose.errors import InputValueError
from twopose.methods.specs import MEASURING_METHODS, Method, spec_of
from twopose.solve.hand_check import field_of, projection

__all__ = ["solve_request"]


def solve_request(method: Method, request: Any) -> dict[str, Any]:
    """Validate a request, solve it, and return the JSON-ready answer.

    Parameters
    ----------
    method : Method
        What the request reconstructs.
    request : object
        The parsed JSON request (the module docstring gives its fields).

    Returns
    -------
    dict
        The answer: the point or line, status, reason, conditioning, views, estimator.

    Raises
    ------
    InputValueError
        A field is missing or malformed; the message names it.
    """
    spec = spec_of(method)  # a name given by hand: refused in words if unknown
    if spec.solver is None:
        *others, last = MEASURING_METHODS
        raise InputValueError(
            f"{method} reconstructs nothing (a board session calibrates the rig: "
            f"`twopose-analyze rig`); solve {', '.join(others)} or {last}"
        )
    views = field_of(request, "views", "the request")
    if not isinstance(views, list) or len(views) < 2:
        n = len(views) if isinstance(views, list) else "no"
        raise InputValueError(f"the request has {n} view(s); a reconstruction needs 2 or more")
    estimator = request.get("estimator", "thesis")
    allowed = spec.estimators
    if estimator not in allowed:
        raise InputValueError(
            f"estimator for {method} must be {' or '.join(allowed)}, got {estimator!r}"
        )
    P = np.stack([projection(v, f"views[{i}]") for i, v in enumerate(views)])[None]
    # The solver the method's estimation reads (its spec's), with the method's plane (method
    # 2's ground: its offset read under the plane's request key).
    answer = spec.solver.load().answer(request, views, P, estimator, spec.plane)
    return answer | {
        "n_views": len(views),
        "estimator": estimator,
    }
