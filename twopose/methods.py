"""The reconstruction methods as a type, with one registry of what each one is.

Every rule that depends on the method reads it here: which target the detector looks for,
what ground truth a trial carries, whether the ground plane is needed, whether the estimate
is a line, which degeneracy margins and extra table columns apply, and how the thesis names
it. Adding a method is adding a :class:`MethodSpec`; nothing else compares method names.

``Method`` is a :class:`~enum.StrEnum`: its members equal their names (``Method.POINT ==
"point"``), print as them and serialise as them, so session files, tables and JSON are the
same as when the method was a plain string.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass
from enum import StrEnum
from types import MappingProxyType
from typing import Literal

from twopose.choices import Target
from twopose.errors import InputValueError

__all__ = [
    "LINE_TRUTH",
    "MEASURING_METHODS",
    "METHODS",
    "METHOD_SPECS",
    "POINT_TRUTH",
    "TRUTH_POINTS",
    "Method",
    "MethodSpec",
    "Solver",
    "TruthKind",
    "label_of",
    "spec_of",
]

#: The ground truth a trial carries: one point, or a line's two points.
TruthKind = Literal["point", "line"]
#: How a method's measurements become its estimate (:func:`twopose.estimate.solve_batch`):
#: the rays through each view's dot (thesis eq. 3.9), the planes of each view's image line
#: and their line (eq. 3.17), or those planes cut by the ground plane y = h (method 2).
Solver = Literal["rays", "planes", "planes and ground"]
#: A trial's truth is one point (the point and ground methods).
POINT_TRUTH: TruthKind = "point"
#: A trial's truth is a line's two points (the line method).
LINE_TRUTH: TruthKind = "line"
#: How many grid points each kind of truth has.
TRUTH_POINTS: Mapping[str, int] = MappingProxyType({POINT_TRUTH: 1, LINE_TRUTH: 2})


class Method(StrEnum):
    """What a session reconstructs (docs/method.md; the thesis' method 1, the line, method 2)."""

    POINT = "point"  # method 1: a fixed dot, two rays (thesis eq. for [p1, -R p2] a = d)
    LINE = "line"  # a fixed line: each image line back-projects to a plane
    GROUND = "ground"  # method 2: the glove's planes meet the ground plane y = h
    BOARD = "board"  # no reconstruction: a checkerboard's corners calibrate the rig (issue 24)


@dataclass(frozen=True, kw_only=True)
class MethodSpec:
    """What one method is, for every stage that depends on it."""

    #: The method this entry describes (its key in :data:`METHOD_SPECS`).
    method: Method
    #: What the detector looks for in each frame (twopose.detect): the dark dot or the glove;
    #: None for a board session, whose corners the rig calibration finds (twopose.rig.board).
    target: Target | None
    #: The ground truth a trial carries: one point, or a line's two points; None for a board
    #: session, whose truth is the board's placement (the session entry's ``board``).
    truth_kind: TruthKind | None
    #: Whether the estimate needs the ground plane y = h (the session's ground height).
    needs_ground: bool
    #: How its measurements are solved (None: a board session reconstructs nothing).
    solver: Solver | None
    #: Degeneracy margins (trials.csv columns, degrees) that apply to the method.
    margins: tuple[str, ...]
    #: The method's own trials.csv columns beside the common ones (analysis/columns.py).
    extra_columns: tuple[str, ...]
    #: How the thesis names it, and how tables and verdicts label it.
    thesis_name: str
    #: Its label in tables, figures and the console ("point (method 1)", "line").
    label: str
    #: The estimators a measurement of it can be solved by (``thesis`` first): the
    #: thesis' formulas, the reprojection-optimal fit, the weighted plane fit.
    estimators: tuple[str, ...] = ("thesis",)
    #: Its colour in every figure over a run (matplotlib's cycle; the sensitivity figure's).
    colour: str = "C4"
    #: Whether the thesis tested it (its verdict lines set a run against the thesis).
    thesis_tested: bool = False
    #: The detector's systematic error per view, (centroid px, orientation degrees) 1-sigma:
    #: what stays when its frames are averaged (the blob's centroid and axis against the
    #: target's projection, the same in every frame of a pose), so the frame scatter cannot
    #: see it. Measured on rendered views (benchmarks/bench_detector_floor.py, which fails
    #: if a measured error exceeds it); added to each view's pixel covariance.
    detector_floor: tuple[float, float] = (0.0, 0.0)
    #: What a top view draws for one view, how it names the truth, and its caption.
    view_segment: str = "segment"
    #: How a top view names the truth in its legend.
    truth_name: str = "truth"
    #: The top view's caption: what it draws for each view.
    top_view: str = "each view"

    @property
    def measures(self) -> bool:
        """Whether the session reconstructs something (a board session calibrates the rig)."""
        return self.target is not None

    @property
    def truth_points(self) -> int:
        """How many ground-truth points a trial has (a line's two ends; none on a board)."""
        return TRUTH_POINTS.get(self.truth_kind, 0) if self.truth_kind else 0

    @property
    def estimates_line(self) -> bool:
        """Whether the estimate is a 3-D line (a point on it and a direction)."""
        return self.truth_kind == LINE_TRUTH

    @property
    def uses_image_lines(self) -> bool:
        """Whether each view's measurement is an image line (orientation) and not a point."""
        return self.target == "glove"


#: The method registry: each method's :class:`MethodSpec`, in the order the thesis presents
#: them, then the board. Every rule that depends on the method reads it here.
METHOD_SPECS: Mapping[Method, MethodSpec] = MappingProxyType(
    {
        Method.POINT: MethodSpec(
            method=Method.POINT,
            target="dot",
            truth_kind="point",
            needs_ground=False,
            solver="rays",
            margins=("parallax_deg",),
            extra_columns=("x_optimal", "y_optimal", "z_optimal", "err_optimal"),
            thesis_name="method 1",
            label="point (method 1)",
            thesis_tested=True,
            estimators=("thesis", "optimal"),
            detector_floor=(0.05, 0.0),
            colour="C1",
            view_segment="ray through the dot, per view",
            top_view="each view's ray through the dot, from its typed camera centre: the rays "
            "meet at the estimate",
        ),
        Method.LINE: MethodSpec(
            method=Method.LINE,
            target="glove",
            truth_kind="line",
            needs_ground=False,
            solver="planes",
            margins=("parallax_deg", "plane_angle_deg"),
            extra_columns=("dir_x", "dir_y", "dir_z", "angle_err_deg", "dist_err"),
            thesis_name="fixed line",
            label="line",
            estimators=("thesis", "weighted", "optimal"),
            detector_floor=(0.1, 0.08),
            colour="C2",
            view_segment="estimated line",
            truth_name="truth (true segment's midpoint)",
            top_view="the estimated line through its reported point; the circle is the true "
            "segment's midpoint",
        ),
        Method.GROUND: MethodSpec(
            method=Method.GROUND,
            target="glove",
            truth_kind="point",
            needs_ground=True,
            solver="planes and ground",
            margins=("parallax_deg", "plane_angle_deg", "line_ground_angle_deg"),
            extra_columns=(),
            thesis_name="method 2",
            label="ground (method 2)",
            thesis_tested=True,
            detector_floor=(0.1, 0.08),
            colour="C0",
            view_segment="view plane's trace on the ground",
            top_view="each view's plane (the finger's image line back-projected) cut by the "
            "ground: the traces meet at the estimate, the ground point the finger points at "
            "(not the finger)",
        ),
        Method.BOARD: MethodSpec(
            method=Method.BOARD,
            target=None,
            truth_kind=None,
            needs_ground=False,
            solver=None,
            margins=(),
            extra_columns=(),
            thesis_name="board (rig calibration)",
            label="board (rig calibration)",
        ),
    }
)
#: The methods' names, in the order the thesis presents them, then the board.
METHODS: tuple[Method, ...] = tuple(METHOD_SPECS)
#: The methods that reconstruct something (every one but the board).
MEASURING_METHODS: tuple[Method, ...] = tuple(m for m, s in METHOD_SPECS.items() if s.measures)


def label_of(method: object) -> str:
    """How tables and verdicts name ``method``: its :attr:`MethodSpec.label`.

    A name the registry does not know is shown as it is.
    """
    try:
        return spec_of(str(method)).label
    except InputValueError:
        return str(method)


def spec_of(method: str) -> MethodSpec:
    """The spec of ``method`` (a :class:`Method` or its name).

    An unknown name raises :class:`~twopose.errors.InputValueError` listing the known ones.
    """
    try:
        return METHOD_SPECS[Method(method)]
    except ValueError:
        raise InputValueError(
            f"method must be one of {', '.join(METHODS)}, got {method!r}"
        ) from None
