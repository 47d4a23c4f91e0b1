"""The measuring methods: their registry and their geometry.

What every stage asks of a method (``specs``: :class:`MethodSpec`, ``spec_of``), the planes
a method's estimate lies on (``planes``), the pointing finger's geometry (``targets``), the
comparison with the typed truth (``truth``) and a trial seen from above as the solver solved
it (``topview``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from twopose.methods.planes import (
        CONSTRAINT_PLANES,
        GRID_AXES,
        GROUND_PLANE,
        ConstraintPlane,
        register_plane,
    )
    from twopose.methods.specs import (
        LINE_TRUTH,
        MEASURING_METHODS,
        METHOD_SPECS,
        METHODS,
        PLANES,
        POINT_TRUTH,
        TRUTH_POINTS,
        Method,
        MethodPage,
        MethodSpec,
        Solver,
        TruthKind,
        label_of,
        register_method,
        spec_of,
    )
    from twopose.methods.targets import (
        FINGER_LENGTH,
        FINGER_TIP_HEIGHT,
        BoardPlacement,
        finger_axis,
    )
    from twopose.methods.topview import TopView, board_top_view, top_view
    from twopose.methods.truth import (
        Reported,
        line_errors,
        reported,
        reported_line_point,
        reporting_anchor,
    )

__all__ = [
    "CONSTRAINT_PLANES",
    "FINGER_LENGTH",
    "FINGER_TIP_HEIGHT",
    "GRID_AXES",
    "GROUND_PLANE",
    "LINE_TRUTH",
    "MEASURING_METHODS",
    "METHODS",
    "METHOD_SPECS",
    "PLANES",
    "POINT_TRUTH",
    "TRUTH_POINTS",
    "BoardPlacement",
    "ConstraintPlane",
    "Method",
    "MethodPage",
    "MethodSpec",
    "Reported",
    "Solver",
    "TopView",
    "TruthKind",
    "board_top_view",
    "finger_axis",
    "label_of",
    "line_errors",
    "register_method",
    "register_plane",
    "reported",
    "reported_line_point",
    "reporting_anchor",
    "spec_of",
    "top_view",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "CONSTRAINT_PLANES": "twopose.methods.planes",
    "FINGER_LENGTH": "twopose.methods.targets",
    "FINGER_TIP_HEIGHT": "twopose.methods.targets",
    "GRID_AXES": "twopose.methods.planes",
    "GROUND_PLANE": "twopose.methods.planes",
    "LINE_TRUTH": "twopose.methods.specs",
    "MEASURING_METHODS": "twopose.methods.specs",
    "METHODS": "twopose.methods.specs",
    "METHOD_SPECS": "twopose.methods.specs",
    "PLANES": "twopose.methods.specs",
    "POINT_TRUTH": "twopose.methods.specs",
    "TRUTH_POINTS": "twopose.methods.specs",
    "BoardPlacement": "twopose.methods.targets",
    "ConstraintPlane": "twopose.methods.planes",
    "Method": "twopose.methods.specs",
    "MethodPage": "twopose.methods.specs",
    "MethodSpec": "twopose.methods.specs",
    "Reported": "twopose.methods.truth",
    "Solver": "twopose.methods.specs",
    "TopView": "twopose.methods.topview",
    "TruthKind": "twopose.methods.specs",
    "board_top_view": "twopose.methods.topview",
    "finger_axis": "twopose.methods.targets",
    "label_of": "twopose.methods.specs",
    "line_errors": "twopose.methods.truth",
    "register_method": "twopose.methods.specs",
    "register_plane": "twopose.methods.planes",
    "reported": "twopose.methods.truth",
    "reported_line_point": "twopose.methods.truth",
    "reporting_anchor": "twopose.methods.truth",
    "spec_of": "twopose.methods.specs",
    "top_view": "twopose.methods.topview",
}

__getattr__, __dir__ = lazy_exports("twopose.methods", _HOMES, __all__)
