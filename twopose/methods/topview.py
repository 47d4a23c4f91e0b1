"""A trial seen face on its method's plane, drawn as the solver solved it.

The plane's two in-plane axes (:attr:`twopose.methods.specs.MethodSpec.seen_on`'s
:meth:`~twopose.methods.planes.ConstraintPlane.in_plane`), session units: for method 2 on the
ground and for the methods on no plane, the grid seen from above, x across and z in depth;
for a method on a wall ``x = c``, the wall seen from in front, y across and z. What each
view measured, drawn so that it meets where the solver says the target is.

- method 1 (point): each view's ray through the dot's centroid, from the camera centre;
  the rays meet at the estimate;
- method 2 (a plane's): each view's plane (the finger's image line back-projected, thesis
  eq. 3.15) cut by the method's plane through the estimate, a line on the plane; the traces
  meet at the point the finger points at, which is the estimate (not at the finger);
- the fixed line: the estimated 3-D line, and the true one when typed;
- a board session (:func:`board_top_view`): the board and where it was seen from.

Which of these a trial draws is its method's geometry's
(:attr:`twopose.methods.specs.MethodSpec.geometry`, asked once through
:class:`twopose.methods.geometry.GeometryCases`): a registered method on a wall draws its
traces on the wall, with no switch here. Each segment's kind carries its style
(:class:`SegmentKind`), so the console draws a new kind without a line of its script.

Pure geometry from a :class:`twopose.display.scene.TrialScene`, for the web console's canvas
(:mod:`recorder.console.state`) and the report's figure; no drawing here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from typing_extensions import override

from twopose.arrays import F64
from twopose.camera.model import grid_rays
from twopose.display.scene import TrialScene
from twopose.methods.planes import GROUND_PLANE, ConstraintPlane
from twopose.methods.specs import Method, spec_of
from twopose.methods.targets import BoardPlacement
from twopose.solve.nview import image_lines, projection_matrices
from twopose.values.checks import Vec3

__all__ = [
    "CORNERS",
    "ESTIMATED_LINE",
    "RAY",
    "SEGMENT_KINDS",
    "TRACE",
    "TRUTH_LINE",
    "SegmentKind",
    "TopView",
    "board_top_view",
    "top_view",
]

#: A point in the plane's two in-plane axes (the ground's x and z), session units.
XZ = tuple[float, float]


class SegmentKind(str):
    """A kind of segment the top view draws: a ``str`` (its name) that carries its style.

    The console draws a new kind as it is declared here, no line of its script edited:
    ``colour`` (CSS), ``width`` (px) and ``dash`` (px on, off; empty: solid) travel with
    each segment in :meth:`TopView.to_json`; the page's legend names the kind as a
    method's :attr:`twopose.methods.specs.MethodPage.legend_segments` says.
    """

    colour: str
    width: float
    dash: tuple[float, ...]

    def __new__(
        cls, name: str, *, colour: str, width: float = 2.0, dash: tuple[float, ...] = ()
    ) -> SegmentKind:
        """The kind ``name`` drawn in ``colour``, ``width`` px wide, ``dash``-ed."""
        kind = super().__new__(cls, name)
        kind.colour, kind.width, kind.dash = colour, width, dash
        return kind

    def __reduce__(self) -> tuple[object, tuple[object, ...]]:
        """Pickled with its style (a report's worker gets the kind whole)."""
        return _segment_kind, (str(self), self.colour, self.width, self.dash)

    def style(self) -> dict[str, object]:
        """How the page draws it (the segment's ``style`` in :meth:`TopView.to_json`)."""
        return {"colour": self.colour, "width": self.width, "dash": list(self.dash)}


def _segment_kind(name: str, colour: str, width: float, dash: tuple[float, ...]) -> SegmentKind:
    return SegmentKind(name, colour=colour, width=width, dash=dash)


#: Method 1's: each view's ray through the dot.
RAY = SegmentKind("ray", colour="#e07b00")
#: Method 2's: each view's plane's trace on the method's plane.
TRACE = SegmentKind("trace", colour="#8e44ad")
#: The fixed line's estimate.
ESTIMATED_LINE = SegmentKind("estimated_line", colour="#d62728", width=3.0)
#: The fixed line's truth, when typed (dashed: the estimate may lie under it).
TRUTH_LINE = SegmentKind("truth_line", colour="#2ca02c", dash=(7.0, 5.0))
#: A board session's board (its inner corners' row, from above).
CORNERS = SegmentKind("corners", colour="#333f4d", width=3.0)
#: Every kind this module draws.
SEGMENT_KINDS: tuple[SegmentKind, ...] = (RAY, TRACE, ESTIMATED_LINE, TRUTH_LINE, CORNERS)


@dataclass(frozen=True, kw_only=True)
class TopView:
    """What the view face on the method's plane draws.

    Every point is in the plane's two in-plane axes, session units
    (:meth:`twopose.methods.planes.ConstraintPlane.in_plane`: the ground's (x, z)).
    """

    trial: int
    method: str
    cameras: tuple[XZ, ...]
    #: (kind, start, end): ``ray`` (point), ``trace`` (method 2: a view's plane on its plane),
    #: ``estimated_line`` (the estimated 3-D line), ``truth_line``, ``corners`` (a board
    #: session's board, its inner corners' row from above). The console's legend names
    #: each kind as the method's :attr:`twopose.methods.specs.MethodPage.legend_segments` says.
    segments: tuple[tuple[SegmentKind, XZ, XZ], ...]
    estimate: XZ | None
    truth: XZ | None  # a point target's true position (lines: a truth_line segment)

    def to_json(self) -> dict[str, object]:
        """The view as a JSON object (the report's top-view data)."""
        return {
            "trial": self.trial,
            "method": self.method,
            "cameras": [list(c) for c in self.cameras],
            "segments": [
                {"kind": str(kind), "style": kind.style(), "from": list(a), "to": list(b)}
                for kind, a, b in self.segments
            ],
            "estimate": None if self.estimate is None else list(self.estimate),
            "truth": None if self.truth is None else list(self.truth),
        }


def board_top_view(board: BoardPlacement, seen_from: Sequence[Vec3]) -> TopView:
    """A board session from above: the board, and where it was seen from.

    The board is the span of its inner corners in its plane z = const; the cameras are
    the typed centres of the accepted captures that saw it.
    """
    corners = board.corners_grid()
    left, right = corners[np.argmin(corners[:, 0])], corners[np.argmax(corners[:, 0])]
    on = GROUND_PLANE  # a board session is drawn from above
    seen = (_xz(on, np.asarray(t, dtype=np.float64)) for t in seen_from)
    cameras = tuple(c for c in seen if c)
    segments = _segments(on, CORNERS, left[None], right[None])
    return TopView(
        trial=0,
        method=Method.BOARD,
        cameras=cameras,
        segments=tuple(segments),
        estimate=None,
        truth=None,
    )


def _xz(on: ConstraintPlane, p: F64) -> XZ | None:
    """``p`` (3,) in the plane's in-plane axes; None when it is not finite."""
    if not np.isfinite(p).all():
        return None
    a, b = on.in_plane(p)
    return (float(a), float(b))


def top_view(scene: TrialScene, on: ConstraintPlane | None = None) -> TopView:
    """The trial face on ``on`` (see the module docstring).

    ``on``: its method's plane by default (:attr:`~twopose.methods.specs.MethodSpec.seen_on`);
    the console passes the ground, whose paper its map and suggestions are drawn on.
    """
    estimate = scene.estimate if np.isfinite(scene.estimate).all() else None
    reach = _reach(scene, estimate)
    spec = spec_of(scene.method)  # the scene's method, as its table names it
    on = on or spec.seen_on
    drawn = spec.geometry_cases(_Drawn(on, scene, estimate, reach))
    segments, truth = drawn.segments(), drawn.truth()
    cameras = tuple(c for c in (_xz(on, t) for t in scene.t_grid) if c is not None)
    return TopView(
        trial=scene.trial,
        method=scene.method,
        cameras=cameras,
        segments=tuple(segments),
        estimate=None if estimate is None else _xz(on, estimate),
        truth=truth,
    )


Segments = list[tuple[SegmentKind, XZ, XZ]]


@dataclass(frozen=True)
class _Seen:
    """What a trial draws on ``on``: what each view measured, and the truth."""

    on: ConstraintPlane
    scene: TrialScene
    estimate: F64 | None
    reach: F64

    def segments(self) -> Segments:
        """What each view measured, face on the plane."""
        return []

    def truth(self) -> XZ | None:
        """The true point, face on the plane."""
        return _xz(self.on, self.scene.truth[0])


class _Rays(_Seen):
    """Method 1's: the rays through the dot; they meet at the estimate."""

    @override
    def segments(self) -> Segments:
        return _rays(self.on, self.scene, self.reach)


class _Line(_Seen):
    """The fixed line's: the estimated line and the true one (seen end-on: its midpoint)."""

    @override
    def segments(self) -> Segments:
        return _lines(self.on, self.scene, self.estimate, self.reach)

    @override
    def truth(self) -> XZ | None:
        return _end_on(self.on, self.scene.truth)


class _Traces(_Seen):
    """Method 2's (any plane's): each view's plane's trace on the plane drawn."""

    @override
    def segments(self) -> Segments:
        return _plane_traces(self.on, self.scene, self.estimate, self.reach)


@dataclass(frozen=True)
class _Drawn:
    """Each geometry's drawing (:class:`twopose.methods.geometry.GeometryCases`)."""

    on: ConstraintPlane
    scene: TrialScene
    estimate: F64 | None
    reach: F64

    def rays_to_point(self) -> _Seen:
        return _Rays(self.on, self.scene, self.estimate, self.reach)

    def planes_to_line(self) -> _Seen:
        return _Line(self.on, self.scene, self.estimate, self.reach)

    def planes_to_plane_point(self, plane: ConstraintPlane) -> _Seen:  # noqa: ARG002 - drawn on ``on``
        return _Traces(self.on, self.scene, self.estimate, self.reach)


def _end_on(on: ConstraintPlane, truth: F64) -> XZ | None:
    """A true line seen end-on (along the plane's normal): its midpoint, as a point.

    From above, a near vertical line; its segment would be drawn as nothing.
    """
    if not np.isfinite(truth).all():
        return None
    d = truth[1] - truth[0]
    length = float(np.linalg.norm(d))
    if length == 0 or np.hypot(*on.in_plane(d)) > 0.05 * length:
        return None
    return _xz(on, 0.5 * (truth[0] + truth[1]))


def _reach(scene: TrialScene, estimate: F64 | None) -> F64:
    """How far to draw from each camera: a little past the estimate (10 units without)."""
    if estimate is None:
        return np.full(len(scene.t_grid), 10.0)
    return np.asarray(1.2 * np.linalg.norm(estimate - scene.t_grid, axis=1))


def _rays(on: ConstraintPlane, scene: TrialScene, reach: F64) -> Segments:
    d = grid_rays(scene.px, scene.intrinsics, scene.R_cam_to_grid)
    ends = scene.t_grid + d * reach[:, None]
    return _segments(on, RAY, scene.t_grid, ends)


def _view_planes(scene: TrialScene) -> F64:
    """Each view's image line back-projected to its plane (N, 4).

    The plane ``pi = P^T l`` in the grid frame: ``pi . (x, y, z, 1) = 0``.
    """
    P = projection_matrices(scene.intrinsics, scene.R_cam_to_grid, scene.t_grid)
    lines = image_lines(scene.px, scene.theta_deg)
    return np.asarray(np.einsum("nji,nj->ni", P, lines))


def _plane_traces(
    on: ConstraintPlane, scene: TrialScene, estimate: F64 | None, reach: F64
) -> Segments:
    """Each view's plane cut by the method's plane through the estimate, in its axes.

    For the ground, by the horizontal plane at the estimate's height.
    """
    if estimate is None:
        return []
    planes = _view_planes(scene)
    # The view plane pi . (p, 1) = 0 on the plane's points s n + u a + v b (s = n . the
    # estimate): (pi . a) u + (pi . b) v + (pi . n) s + d = 0, a line in (u, v). For the
    # ground, pi . a and pi . b are pi's x and z, exactly.
    height = float(on.along_normal(estimate))
    in_plane, across = on.in_plane(planes[:, :3]), on.along_normal(planes[:, :3])
    at = on.in_plane(estimate)
    out = []
    for plane, (a, c), b, length in zip(planes, in_plane, across, reach, strict=True):
        d = plane[3]
        normal = np.array([a, c])
        norm = float(np.linalg.norm(normal))
        if not np.isfinite(plane).all() or norm < 1e-12:
            continue
        # The trace's point nearest the estimate, then along it.
        offset = (a * at[0] + c * at[1] + b * height + d) / norm
        foot = at - offset * normal / norm
        along = np.array([-normal[1], normal[0]]) / norm * 0.5 * length
        out.append((TRACE, _pair(foot - along), _pair(foot + along)))
    return out


def _lines(on: ConstraintPlane, scene: TrialScene, estimate: F64 | None, reach: F64) -> Segments:
    """The estimated line, and the true line drawn as long as it, after it (on top).

    Between its two typed points alone the true line can hide under the estimate.
    """
    out: Segments = []
    direction = scene.direction
    span = 0.6 * float(np.mean(reach))
    if estimate is not None and direction is not None and np.isfinite(direction).all():
        out += _segments(
            on,
            ESTIMATED_LINE,
            (estimate - span * direction)[None],
            (estimate + span * direction)[None],
        )
    if np.isfinite(scene.truth).all():
        a, b = scene.truth[0], scene.truth[1]
        length = float(np.linalg.norm(b - a))
        if length > 0:
            mid, along = 0.5 * (a + b), (b - a) / length
            half = max(span, 0.5 * length)
            ends = (mid - half * along)[None], (mid + half * along)[None]
            out += _segments(on, TRUTH_LINE, *ends)
    return out


def _segments(on: ConstraintPlane, kind: SegmentKind, starts: F64, ends: F64) -> Segments:
    out = []
    for a, b in zip(starts, ends, strict=True):
        pa, pb = _xz(on, a), _xz(on, b)
        if pa is not None and pb is not None:
            out.append((kind, pa, pb))
    return out


def _pair(p: F64) -> XZ:
    return (float(p[0]), float(p[1]))
