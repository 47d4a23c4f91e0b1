"""A trial seen from above, drawn as the solver solved it.

The grid's x across, z in depth, session units: what each view measured, drawn so that it meets
where the solver says the target is.

- method 1 (point): each view's ray through the dot's centroid, from the camera centre;
  the rays meet at the estimate;
- method 2 (ground): each view's plane (the finger's image line back-projected, thesis
  eq. 3.15) cut by the ground plane, a line on the table; the traces meet at the ground
  point the finger points at, which is the estimate (not at the finger);
- the fixed line: the estimated 3-D line, and the true one when typed;
- a board session (:func:`board_top_view`): the board and where it was seen from.

Pure geometry from a :class:`twopose.scene3d.TrialScene`, for the web console's canvas
(:mod:`recorder.console`); no drawing here.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64
from twopose.camera import grid_rays
from twopose.methods import Method, spec_of
from twopose.scene3d import TrialScene
from twopose.solve import image_lines, projection_matrices
from twopose.targets import BoardPlacement
from twopose.values import Vec3

__all__ = ["TopView", "board_top_view", "top_view"]

XZ = tuple[float, float]


@dataclass(frozen=True, kw_only=True)
class TopView:
    """What the top view draws; every point is (x, z) in session units."""

    trial: int
    method: str
    cameras: tuple[XZ, ...]
    #: (kind, start, end): ``ray`` (point), ``trace`` (method 2 plane on the ground),
    #: ``estimated_line`` (the estimated 3-D line), ``truth_line``, ``corners`` (a board
    #: session's board, its inner corners' row from above). The console's legend names
    #: each kind as the method's :attr:`twopose.methods.MethodPage.legend_segments` says.
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
    cameras = tuple(c for c in (_xz(np.asarray(t, dtype=np.float64)) for t in seen_from) if c)
    segments = _segments("corners", left[None], right[None])
    return TopView(
        trial=0,
        method=Method.BOARD,
        cameras=cameras,
        segments=tuple(segments),
        estimate=None,
        truth=None,
    )


def _xz(p: F64) -> XZ | None:
    return (float(p[0]), float(p[2])) if np.isfinite(p).all() else None


def top_view(scene: TrialScene) -> TopView:
    """The trial from above (see the module docstring)."""
    estimate = scene.estimate if np.isfinite(scene.estimate).all() else None
    reach = _reach(scene, estimate)
    spec = spec_of(scene.method)
    if not spec.uses_image_lines:  # method 1: the rays through the dot
        segments = _rays(scene, reach)
    elif spec.needs_ground:  # method 2: the planes' traces on the ground
        segments = _ground_traces(scene, estimate, reach)
    else:
        segments = _lines(scene, estimate, reach)
    truth = _end_on(scene.truth) if spec.estimates_line else _xz(scene.truth[0])
    cameras = tuple(c for c in (_xz(t) for t in scene.t_grid) if c is not None)
    return TopView(
        trial=scene.trial,
        method=scene.method,
        cameras=cameras,
        segments=tuple(segments),
        estimate=None if estimate is None else _xz(estimate),
        truth=truth,
    )


def _end_on(truth: F64) -> XZ | None:
    """A true line seen end-on from above (near vertical): its midpoint, as a point.

    Its segment would be drawn as nothing.
    """
    if not np.isfinite(truth).all():
        return None
    d = truth[1] - truth[0]
    length = float(np.linalg.norm(d))
    if length == 0 or np.hypot(d[0], d[2]) > 0.05 * length:
        return None
    return _xz(0.5 * (truth[0] + truth[1]))


def _reach(scene: TrialScene, estimate: F64 | None) -> F64:
    """How far to draw from each camera: a little past the estimate (10 units without)."""
    if estimate is None:
        return np.full(len(scene.t_grid), 10.0)
    return np.asarray(1.2 * np.linalg.norm(estimate - scene.t_grid, axis=1))


def _rays(scene: TrialScene, reach: F64) -> list[tuple[str, XZ, XZ]]:
    d = grid_rays(scene.px, scene.intrinsics, scene.R_cam_to_grid)
    ends = scene.t_grid + d * reach[:, None]
    return _segments("ray", scene.t_grid, ends)


def _view_planes(scene: TrialScene) -> F64:
    """Each view's image line back-projected to its plane (N, 4).

    The plane ``pi = P^T l`` in the grid frame: ``pi . (x, y, z, 1) = 0``.
    """
    P = projection_matrices(scene.intrinsics, scene.R_cam_to_grid, scene.t_grid)
    lines = image_lines(scene.px, scene.theta_deg)
    return np.asarray(np.einsum("nji,nj->ni", P, lines))


def _ground_traces(scene: TrialScene, estimate: F64 | None, reach: F64) -> list[tuple[str, XZ, XZ]]:
    """Each view's plane cut by the horizontal plane through the estimate (the ground)."""
    if estimate is None:
        return []
    planes = _view_planes(scene)
    y = estimate[1]
    out = []
    for plane, length in zip(planes, reach, strict=True):
        a, b, c, d = plane
        normal = np.array([a, c])
        norm = float(np.linalg.norm(normal))
        if not np.isfinite(plane).all() or norm < 1e-12:
            continue
        # The trace a x + c z + (b y + d) = 0: its point nearest the estimate, then along.
        offset = (a * estimate[0] + c * estimate[2] + b * y + d) / norm
        foot = np.array([estimate[0], estimate[2]]) - offset * normal / norm
        along = np.array([-normal[1], normal[0]]) / norm * 0.5 * length
        out.append(("trace", _pair(foot - along), _pair(foot + along)))
    return out


def _lines(scene: TrialScene, estimate: F64 | None, reach: F64) -> list[tuple[str, XZ, XZ]]:
    """The estimated line, and the true line drawn as long as it, after it (on top).

    Between its two typed points alone the true line can hide under the estimate.
    """
    out: list[tuple[str, XZ, XZ]] = []
    direction = scene.direction
    span = 0.6 * float(np.mean(reach))
    if estimate is not None and direction is not None and np.isfinite(direction).all():
        out += _segments(
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
            out += _segments("truth_line", (mid - half * along)[None], (mid + half * along)[None])
    return out


def _segments(kind: str, starts: F64, ends: F64) -> list[tuple[str, XZ, XZ]]:
    out = []
    for a, b in zip(starts, ends, strict=True):
        pa, pb = _xz(a), _xz(b)
        if pa is not None and pb is not None:
            out.append((kind, pa, pb))
    return out


def _pair(p: F64) -> XZ:
    return (float(p[0]), float(p[1]))
