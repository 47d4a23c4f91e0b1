"""The solvers: from measurements and poses to estimates.

Method 1, the fixed line and method 2 for N >= 2 views with the degeneracy measures they
report (``nview``), many points of one pair of views in closed form (``two_view``), the
reprojection-optimal line (``optimal_lines``), every estimator in one batch (``estimate``, its
options in ``margins``) and a session's trials estimated at once (``session``, the one entry
point).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from twopose.solve.entries import (
        PLANES,
        PLANES_AND_PLANE,
        RAYS,
        GroundSpec,
        PoseView,
        Solved,
        SolverEntry,
        ViewBatch,
        nearest_on_line,
    )
    from twopose.solve.estimate import (
        margin_warnings,
        measure,
        misclosure_residuals,
        pose_view,
        solve_batch,
        thesis_estimate,
    )
    from twopose.solve.hand_check import field_of, projection
    from twopose.solve.margins import EstimateOptions
    from twopose.solve.nview import (
        NViewLines,
        NViewPoints,
        image_lines,
        projection_matrices,
        triangulate_ground,
        triangulate_lines,
        triangulate_points,
    )
    from twopose.solve.session import (
        Estimates,
        SessionEstimate,
        SessionTrials,
        estimate_session,
        running_estimates,
    )
    from twopose.solve.two_view import triangulate_two_views

__all__ = [
    "PLANES",
    "PLANES_AND_PLANE",
    "RAYS",
    "EstimateOptions",
    "Estimates",
    "GroundSpec",
    "NViewLines",
    "NViewPoints",
    "PoseView",
    "SessionEstimate",
    "SessionTrials",
    "Solved",
    "SolverEntry",
    "ViewBatch",
    "estimate_session",
    "field_of",
    "image_lines",
    "margin_warnings",
    "measure",
    "misclosure_residuals",
    "nearest_on_line",
    "pose_view",
    "projection",
    "projection_matrices",
    "running_estimates",
    "solve_batch",
    "thesis_estimate",
    "triangulate_ground",
    "triangulate_lines",
    "triangulate_points",
    "triangulate_two_views",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "PLANES": "twopose.solve.entries",
    "PLANES_AND_PLANE": "twopose.solve.entries",
    "RAYS": "twopose.solve.entries",
    "EstimateOptions": "twopose.solve.margins",
    "Estimates": "twopose.solve.session",
    "GroundSpec": "twopose.solve.entries",
    "NViewLines": "twopose.solve.nview",
    "NViewPoints": "twopose.solve.nview",
    "PoseView": "twopose.solve.entries",
    "SessionEstimate": "twopose.solve.session",
    "SessionTrials": "twopose.solve.session",
    "Solved": "twopose.solve.entries",
    "SolverEntry": "twopose.solve.entries",
    "ViewBatch": "twopose.solve.entries",
    "estimate_session": "twopose.solve.session",
    "field_of": "twopose.solve.hand_check",
    "image_lines": "twopose.solve.nview",
    "margin_warnings": "twopose.solve.estimate",
    "measure": "twopose.solve.estimate",
    "misclosure_residuals": "twopose.solve.estimate",
    "nearest_on_line": "twopose.solve.entries",
    "pose_view": "twopose.solve.estimate",
    "projection": "twopose.solve.hand_check",
    "projection_matrices": "twopose.solve.nview",
    "running_estimates": "twopose.solve.session",
    "solve_batch": "twopose.solve.estimate",
    "thesis_estimate": "twopose.solve.estimate",
    "triangulate_ground": "twopose.solve.nview",
    "triangulate_lines": "twopose.solve.nview",
    "triangulate_points": "twopose.solve.nview",
    "triangulate_two_views": "twopose.solve.two_view",
}

__getattr__, __dir__ = lazy_exports("twopose.solve", _HOMES, __all__)
