"""Where on the grid paper the next pose may go, and what keeps the target in view.

A candidate next pose is a camera centre on the grid paper's lines (the multiples of the
spacing, whatever the first pose) within :class:`Reach` of the trial's first pose (the
laptop stays on the table: y is the first pose's). A candidate is left out when it would
put the target near the image's edge (the centroid within :data:`IN_VIEW_MARGIN` of the
image's size, or either end of the finger within :data:`END_MARGIN`: a blob at the edge is
lost or merges with clutter), over known clutter (:mod:`twopose.detect.clutter`), when it is a
pose already taken, or when the trial would not solve from it (the reasons
:data:`REASONS`).

The poses that keep the target in view form a convex region of the table (the reach's
square cut by one half-plane per image edge and point, :func:`half_planes`), so they are
counted exactly, row by row of the paper (:class:`twopose.guidance.search.Field`, the
lattice the search and the map stand on), however fine the paper and wide the reach.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64, Bools
from twopose.camera.model import rotation_from_angles_deg
from twopose.methods.targets import FINGER_LENGTH
from twopose.solve.estimate import PoseView
from twopose.solve.nview import projection_matrices
from twopose.values.units import Units, unit_factor

__all__ = [
    "CLUTTER",
    "EDGE",
    "END_MARGIN",
    "IN_VIEW_MARGIN",
    "REASONS",
    "TAKEN",
    "UNSOLVED",
    "Reach",
    "clear_of_edges",
    "half_planes",
    "index_range",
    "lattice",
    "project",
    "view_checks",
]

#: A predicted view keeps its centroid this far inside the image (a share of its size):
#: the finger reaches beyond its centroid, and a blob at the edge is lost.
IN_VIEW_MARGIN = 0.2
#: A predicted view keeps either end of the finger (its nominal length, ``FINGER_LENGTH``
#: inches, about its centroid) this far inside the image: a finger that reaches the
#: image's edge merges with what lies there (issue 44: (4.5, 0, 2.5) after (4.5, 0, 0)).
END_MARGIN = 0.1
#: Why a lattice pose in reach was not suggested (:attr:`Suggestion.left_out`, the map's
#: cells): too near the image's edge, ...
EDGE = "near the image's edge"
#: ... already taken, ...
TAKEN = "taken"
#: ... its prediction did not solve, ...
UNSOLVED = "not solved"
#: ... or the target would be seen over known clutter (:mod:`twopose.detect.clutter`).
CLUTTER = "over clutter"
#: Every reason, in the order the map's ``reason`` indexes them (0: none, predicted).
REASONS = ("", EDGE, TAKEN, UNSOLVED, CLUTTER)


@dataclass(frozen=True, kw_only=True)
class Reach:
    """The poses the operator can reach: the grid's lattice about the first pose."""

    radius: float  # session units: |dx|, |dz| from the first pose
    spacing: float  # session units: the grid paper's lines

    @classmethod
    def thesis(cls, units: Units) -> Reach:
        """The thesis' range (moves of 1-3 in about the first pose) on its 1/2 in grid."""
        factor = unit_factor(Units.IN, units)
        return cls(radius=3.0 * factor, spacing=0.5 * factor)

    def __post_init__(self) -> None:
        """Refuse a reach with no lattice."""
        if not (self.spacing > 0 and self.radius >= self.spacing):
            raise ValueError(f"reach: need 0 < spacing <= radius, got {self}")

    def box(self, first: F64) -> tuple[int, int, int, int]:
        """The paper's lines in reach of ``first``: first and last column, first and last row."""
        i0, i1 = index_range(float(first[0]), self.radius, self.spacing)
        j0, j1 = index_range(float(first[2]), self.radius, self.spacing)
        return i0, i1, j0, j1


def index_range(centre: float, radius: float, spacing: float) -> tuple[int, int]:
    """The paper's lines ``k * spacing`` within ``radius`` of ``centre``: first and last k."""
    lo = math.ceil((centre - radius) / spacing - 1e-9)
    hi = math.floor((centre + radius) / spacing + 1e-9)
    return lo, hi


def lattice(first_t: F64, reach: Reach, taken: F64) -> F64:
    """(K, 3) every reachable camera centre on the paper's lines, less those taken.

    The grid paper's lines (x and z multiples of the spacing) within the reach of
    ``first_t`` (``|dx|, |dz| <= radius``), at its height, less those within half a
    spacing of a pose ``taken``. The whole lattice, for small reaches (the brute-force
    reference of the search).
    """
    first = np.asarray(first_t, dtype=np.float64)
    s = reach.spacing
    i0, i1, j0, j1 = reach.box(first)
    ii, jj = np.meshgrid(np.arange(i0, i1 + 1), np.arange(j0, j1 + 1), indexing="ij")
    points = np.column_stack([ii.ravel() * s, np.full(ii.size, first[1]), jj.ravel() * s])
    gaps = np.linalg.norm(points[:, None, :] - np.asarray(taken)[None, :, :], axis=-1)
    return np.asarray(points[(gaps > s / 2).all(axis=1)])


def view_checks(target: F64, units: Units, *, lines: bool) -> tuple[F64, F64]:
    """The points a predicted view must keep inside the image, and their margins.

    The target's centroid (:data:`IN_VIEW_MARGIN`), and for the finger both ends of its
    nominal length about it (:data:`END_MARGIN`).
    """
    if not lines:
        return target[:1], np.array([IN_VIEW_MARGIN])
    d = target[1] - target[0]
    d = d / np.linalg.norm(d)
    half = 0.5 * FINGER_LENGTH * unit_factor(Units.IN, units)
    points = np.stack([target[0], target[0] + half * d, target[0] - half * d])
    return points, np.array([IN_VIEW_MARGIN, END_MARGIN, END_MARGIN])


def project(points: F64, view: PoseView, centres: F64) -> F64:
    """(K, M, 2) pixels of grid ``points`` (M, 3) from each of ``centres`` (K, 3).

    Seen by ``view``'s camera moved there; NaN for a point behind the camera.
    """
    R = rotation_from_angles_deg(view.r_deg)
    P = projection_matrices(view.intrinsics, R, centres)  # (K, 3, 4)
    h = np.einsum("kij,mj->kmi", P, np.column_stack([points, np.ones(len(points))]))
    ahead = h[..., 2:3] > 0
    return np.asarray(np.where(ahead, h[..., :2] / np.where(ahead, h[..., 2:3], 1.0), np.nan))


def clear_of_edges(
    view: PoseView, centres: F64, target: F64, units: Units, *, lines: bool,
    margin: float = 1.0,
) -> Bools:  # fmt: skip
    """(K,) whether ``view``'s camera moved to each of ``centres`` keeps the target clear.

    Clear of the image's edges: its centroid :data:`IN_VIEW_MARGIN` inside, the finger's
    ends :data:`END_MARGIN` inside (a share of the image's width and height), each margin
    times ``margin`` (a first pose's pick for a target whose depth is not known keeps it
    clear by less: :data:`twopose.guidance.first_pose.OTHER_DEPTHS_MARGIN`).
    """
    points, margins = view_checks(target, units, lines=lines)
    margins = margins * margin
    px = project(points, view, np.atleast_2d(centres))
    w, h = view.width_height
    mx, my = margins * w, margins * h
    with np.errstate(invalid="ignore"):
        inside = (
            (px[..., 0] > mx) & (px[..., 0] < w - mx) & (px[..., 1] > my) & (px[..., 1] < h - my)
        )
    return np.asarray(inside.all(axis=1))


def half_planes(
    view: PoseView, target: F64, units: Units, y: float, *, lines: bool, margin: float = 1.0
) -> F64:
    """(H, 3) rows ``(a, b, c)``: a centre keeps the target clear if every ``a x + b z < c``.

    Clear of the image's edges as :func:`clear_of_edges` says, for the centre ``(x, y, z)``.
    A pixel bound ``u > u0`` is ``(A_0 - u0 A_2) . (X - c) > 0`` for ``A = K R^T`` and a
    point in front of the camera: linear in the camera centre ``c``.
    """
    points, margins = view_checks(target, units, lines=lines)
    margins = margins * margin
    fx, fy, cx, cy = view.intrinsics
    K = np.array([[fx, 0.0, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
    A = K @ rotation_from_angles_deg(view.r_deg).T
    w, h = view.width_height
    rows = []
    for X, m in zip(points, margins, strict=True):
        u0, u1, v0, v1 = m * w, w - m * w, m * h, h - m * h
        for a in (A[2], A[0] - u0 * A[2], u1 * A[2] - A[0], A[1] - v0 * A[2], v1 * A[2] - A[1]):
            rows.append([a[0], a[2], float(a @ X) - a[1] * y])
    return np.array(rows)
