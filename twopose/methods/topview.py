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

Pure geometry from a :class:`twopose.display.scene.TrialScene`, for the web console's canvas
(:mod:`recorder.console.state`) and the report's figure; no drawing here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64
from twopose.camera.model import grid_rays
from twopose.display.scene import TrialScene
from twopose.methods.planes import GROUND_PLANE, ConstraintPlane
from twopose.methods.specs import Method, spec_of
from twopose.methods.targets import BoardPlacement
from twopose.solve.nview import image_lines, projection_matrices
from twopose.values.checks import Vec3

__all__ = ["TopView", "board_top_view", "top_view"]

#: A point in the plane's two in-plane axes (the ground's x and z), session units.
XZ = tuple[float, float]


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
    segments: tuple[tuple[str, XZ, XZ], ...]
    estimate: XZ | None
    truth: XZ | None  # a point target's true position (lines: a truth_line segment)

    def to_json(self) -> dict[str, object]:
        """The view as a JSON object (the report's top-view data)."""
        return {
            "trial": self.trial,
            "method": self.method,
            "cameras": [list(c) for c in self.cameras],
            "segments": [
                {"kind": kind, "from": list(a), "to": list(b)} for kind, a, b in self.segments
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
    segments = _segments(on, "corners", left[None], right[None])
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
    spec = spec_of(scene.method)
    on = on or spec.seen_on
    if not spec.uses_image_lines:  # method 1: the rays through the dot
        segments = _rays(on, scene, reach)
    elif spec.needs_plane:  # method 2: the planes' traces on its plane
        segments = _plane_traces(on, scene, estimate, reach)
    else:
        segments = _lines(on, scene, estimate, reach)
    truth = _end_on(on, scene.truth) if spec.estimates_line else _xz(on, scene.truth[0])
    cameras = tuple(c for c in (_xz(on, t) for t in scene.t_grid) if c is not None)
    return TopView(
        trial=scene.trial,
        method=scene.method,
        cameras=cameras,
        segments=tuple(segments),
        estimate=None if estimate is None else _xz(on, estimate),
        truth=truth,
    )


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


def _rays(on: ConstraintPlane, scene: TrialScene, reach: F64) -> list[tuple[str, XZ, XZ]]:
    d = grid_rays(scene.px, scene.intrinsics, scene.R_cam_to_grid)
    ends = scene.t_grid + d * reach[:, None]
    return _segments(on, "ray", scene.t_grid, ends)


def _view_planes(scene: TrialScene) -> F64:
    """Each view's image line back-projected to its plane (N, 4).

    The plane ``pi = P^T l`` in the grid frame: ``pi . (x, y, z, 1) = 0``.
    """
    P = projection_matrices(scene.intrinsics, scene.R_cam_to_grid, scene.t_grid)
    lines = image_lines(scene.px, scene.theta_deg)
    return np.asarray(np.einsum("nji,nj->ni", P, lines))


def _plane_traces(
    on: ConstraintPlane, scene: TrialScene, estimate: F64 | None, reach: F64
) -> list[tuple[str, XZ, XZ]]:
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
        out.append(("trace", _pair(foot - along), _pair(foot + along)))
    return out


def _lines(
    on: ConstraintPlane, scene: TrialScene, estimate: F64 | None, reach: F64
) -> list[tuple[str, XZ, XZ]]:
    """The estimated line, and the true line drawn as long as it, after it (on top).

    Between its two typed points alone the true line can hide under the estimate.
    """
    out: list[tuple[str, XZ, XZ]] = []
    direction = scene.direction
    span = 0.6 * float(np.mean(reach))
    if estimate is not None and direction is not None and np.isfinite(direction).all():
        out += _segments(
            on,
            "estimated_line",
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
            out += _segments(on, "truth_line", *ends)
    return out


def _segments(on: ConstraintPlane, kind: str, starts: F64, ends: F64) -> list[tuple[str, XZ, XZ]]:
    out = []
    for a, b in zip(starts, ends, strict=True):
        pa, pb = _xz(on, a), _xz(on, b)
        if pa is not None and pb is not None:
            out.append((kind, pa, pb))
    return out


def _pair(p: F64) -> XZ:
    return (float(p[0]), float(p[1]))
