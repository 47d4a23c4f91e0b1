"""Where to put the laptop next, and when a trial is precise enough (issue 36).

The trial's predicted 95% region is the one the analysis will report: its poses' views
solved and propagated by :func:`twopose.session_estimate.estimate_session` (pixel scatter,
typed-translation resolution, the calibration's sigma) and reported by the analysis' rule
(:func:`twopose.truth.reported`), the 95% ellipsoid's largest semi-axis (``semiaxis95``).

A candidate next pose is a camera centre on the grid paper's lines (the multiples of the
spacing, whatever the first pose) within :class:`Reach` of the trial's first pose (the
laptop stays on the table: y is the first pose's, the angles the last pose's). Its view is
predicted by projecting the target as the trial's poses locate it: the point (method 1) or
the finger's 3-D line (the fixed line, method 2: the planes' line). Its frames scatter as
the last pose's did. A candidate is left out when it would put the target near the image's
edge (the centroid within :data:`IN_VIEW_MARGIN` of the image's size, or either end of the
finger within :data:`END_MARGIN`: a blob at the edge is lost or merges with clutter), when
it is a pose already taken, or when the trial would not solve from it.

The poses that keep the target in view form a convex region of the table (the reach's
square cut by one half-plane per image edge and point), so they are counted exactly, row
by row of the paper, however fine the paper and wide the reach. Their regions are not all
predicted: a coarse pass over the region (about :data:`COARSE_CANDIDATES` poses, every
row's two ends among them, where the best pose usually lies), then a pattern search on the
paper's own lines from the best few, halving its step down to one line. Each pass is one
batch of trials, one vectorized estimate. ``benchmarks/bench_suggest.py`` measures its cost
and how far its pick's region is from the whole lattice's best.

With one pose the target cannot be located yet (one ray, or one plane). The suggestion is
then the move that best conditions the next intersection for a *provisional* target on the
first view's ray (its centroid's) at :data:`NOMINAL_DEPTH_IN` (nearer if the ray meets the
ground first); for the finger, the provisional line is the one in the view's plane that
points most steeply down. It says so.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64, Bools, Ints
from twopose.camera import grid_rays, rotation_from_angles_deg
from twopose.detect import wrap_theta_deg
from twopose.estimate import EstimateOptions, GroundSpec, PoseView, measure
from twopose.methods import Method, spec_of
from twopose.session_estimate import SessionTrials, estimate_session
from twopose.solve import projection_matrices
from twopose.targets import FINGER_LENGTH
from twopose.truth import reported
from twopose.uncertainty import uncertainty_columns
from twopose.units import Units, unit_factor

__all__ = [
    "COARSE_CANDIDATES",
    "END_MARGIN",
    "IN_VIEW_MARGIN",
    "LOOKAHEAD_POSES",
    "NOMINAL_DEPTH_IN",
    "THESIS_MOVE_IN",
    "Advice",
    "Guidance",
    "Reach",
    "Suggestion",
    "advise",
    "clear_of_edges",
    "lattice",
    "predicted_regions",
    "regions95",
    "suggest",
]

#: The thesis' move from one pose to the next: about an inch along x (Appendix D's 1.1 in).
THESIS_MOVE_IN = (1.0, 0.0, 0.0)
#: Where a target seen from one pose is assumed, along its ray (the thesis' ~10 in).
NOMINAL_DEPTH_IN = 10.0
#: A predicted view keeps its centroid this far inside the image (a share of its size):
#: the finger reaches beyond its centroid, and a blob at the edge is lost.
IN_VIEW_MARGIN = 0.2
#: A predicted view keeps either end of the finger (its nominal length, ``FINGER_LENGTH``
#: inches, about its centroid) this far inside the image: a finger that reaches the
#: image's edge merges with what lies there (issue 44: (4.5, 0, 2.5) after (4.5, 0, 0)).
END_MARGIN = 0.1
#: The coarse pass predicts about this many poses (the whole lattice when it holds fewer
#: than :data:`_EXHAUSTIVE`); the pattern search refines from its best.
COARSE_CANDIDATES = 40
#: A lattice of at most this many poses in view is predicted whole.
_EXHAUSTIVE = 60
#: The pattern search starts from this many of the coarse pass' best poses, apart (a
#: second one only within :data:`_SEED_WITHIN` of the best: another side of the table).
_SEEDS = 2
_SEED_WITHIN = 0.05
#: The pattern search stops where its neighbours' regions differ by less than this share:
#: a finer step could gain no more than about that.
_FLAT = 0.002
#: On the field's edge, the pattern search also looks this many steps along it.
_EDGE_WALK = 4
#: The prediction of how many poses are still needed searches more coarsely (no pattern
#: search) ...
_LOOKAHEAD_COARSE = 10
#: ... and looks at most this many poses ahead (its cost grows with each).
LOOKAHEAD_POSES = 4
#: The pattern search's rounds, at most (each one batch).
_MAX_ROUNDS = 40
#: Why a lattice pose in reach was not suggested (:attr:`Suggestion.left_out`).
EDGE, TAKEN, UNSOLVED = "near the image's edge", "taken", "not solved"


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


@dataclass(frozen=True, kw_only=True)
class Suggestion:
    """The next pose that shrinks the trial's predicted 95% region most."""

    t_grid: tuple[float, float, float]
    r_deg: tuple[float, float, float]
    predicted95: float  # session units: the region with that pose added
    thesis_t_grid: tuple[float, float, float]
    thesis95: float  # the region with the thesis' default move instead (NaN: out of view)
    provisional: bool  # one pose: the target's place along its ray was assumed
    n_candidates: int  # lattice poses in reach that keep the target in view, not taken
    #: How many lattice poses in reach were left out, and why (:data:`EDGE`, :data:`TAKEN`,
    #: :data:`UNSOLVED`: of those predicted), the reasons with none omitted.
    left_out: tuple[tuple[str, int], ...] = ()
    n_predicted: int = 0  # candidates whose region was predicted (the search's cost)

    def text(self, units: Units) -> str:
        """One line for the operator."""
        x, y, z = self.t_grid
        line = (
            f"next pose: x {x:g}, y {y:g}, z {z:g} {units} "
            f"(predicted 95% within {self.predicted95:.3g} {units}"
        )
        if math.isfinite(self.thesis95):
            tx, ty, tz = self.thesis_t_grid
            line += f"; the thesis' move to {tx:g}, {ty:g}, {tz:g} would give {self.thesis95:.3g}"
        line += ")"
        if self.provisional:
            line += (
                "; one pose cannot locate the target yet: this move best conditions the "
                "next intersection, the target assumed on the first view's ray"
            )
        said = self.left_out_text()
        if said:
            line += f"; {said}"
        return line

    def left_out_text(self) -> str:
        """Why reachable grid poses were not suggested, in words ("" when none was)."""
        words = {
            EDGE: "would put the target near the image's edge",
            TAKEN: "already taken",
            UNSOLVED: "would leave the trial unsolved",
        }
        parts = [f"{n} {words.get(reason, reason)}" for reason, n in self.left_out if n]
        return "left out of the grid poses in reach: " + ", ".join(parts) if parts else ""

    def to_json(self) -> dict[str, object]:
        """What the browser console shows (its marker and the values the pose form takes)."""
        return {
            "t_grid": list(self.t_grid),
            "r_deg": list(self.r_deg),
            "predicted95": self.predicted95,
            "thesis_t_grid": list(self.thesis_t_grid),
            "thesis95": self.thesis95,
            "provisional": self.provisional,
            "left_out": self.left_out_text(),
        }


def _index_range(centre: float, radius: float, spacing: float) -> tuple[int, int]:
    """The paper's lines ``k * spacing`` within ``radius`` of ``centre``: first and last k."""
    lo = math.ceil((centre - radius) / spacing - 1e-9)
    hi = math.floor((centre + radius) / spacing + 1e-9)
    return lo, hi


def lattice(first_t: F64, reach: Reach, taken: F64) -> F64:
    """(K, 3) every reachable camera centre on the paper's lines, less those taken.

    The grid paper's lines (x and z multiples of the spacing) within the reach of
    ``first_t`` (``|dx|, |dz| <= radius``), at its height, less those within half a
    spacing of a pose ``taken``. The whole lattice, for small reaches (the brute-force
    reference of the search in :func:`suggest`).
    """
    first = np.asarray(first_t, dtype=np.float64)
    s = reach.spacing
    i0, i1 = _index_range(float(first[0]), reach.radius, s)
    j0, j1 = _index_range(float(first[2]), reach.radius, s)
    ii, jj = np.meshgrid(np.arange(i0, i1 + 1), np.arange(j0, j1 + 1), indexing="ij")
    points = np.column_stack([ii.ravel() * s, np.full(ii.size, first[1]), jj.ravel() * s])
    gaps = np.linalg.norm(points[:, None, :] - np.asarray(taken)[None, :, :], axis=-1)
    return np.asarray(points[(gaps > s / 2).all(axis=1)])


def regions95(trials: SessionTrials, options: EstimateOptions) -> F64:
    """(T,) each trial's 95% region as the analysis reports it (NaN: not solved)."""
    estimate = estimate_session(trials, options, line_fits=False)  # the thesis' line's region
    rep = reported(estimate)
    regions = uncertainty_columns(rep.error, rep.cov)["semiaxis95"]
    return np.where(estimate.estimates.status == "ok", regions, np.nan)


def _view_checks(target: F64, units: Units, *, lines: bool) -> tuple[F64, F64]:
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


def _project_all(points: F64, view: PoseView, centres: F64) -> F64:
    """(K, M, 2) pixels of grid ``points`` (M, 3) from each of ``centres`` (K, 3).

    Seen by ``view``'s camera moved there; NaN for a point behind the camera.
    """
    R = rotation_from_angles_deg(view.r_deg)
    P = projection_matrices(view.intrinsics, R, centres)  # (K, 3, 4)
    h = np.einsum("kij,mj->kmi", P, np.column_stack([points, np.ones(len(points))]))
    ahead = h[..., 2:3] > 0
    return np.asarray(np.where(ahead, h[..., :2] / np.where(ahead, h[..., 2:3], 1.0), np.nan))


def clear_of_edges(
    view: PoseView, centres: F64, target: F64, units: Units, *, lines: bool
) -> Bools:
    """(K,) whether ``view``'s camera moved to each of ``centres`` keeps the target clear.

    Clear of the image's edges: its centroid :data:`IN_VIEW_MARGIN` inside, the finger's
    ends :data:`END_MARGIN` inside (a share of the image's width and height).
    """
    points, margins = _view_checks(target, units, lines=lines)
    px = _project_all(points, view, np.atleast_2d(centres))
    w, h = view.width_height
    mx, my = margins * w, margins * h
    with np.errstate(invalid="ignore"):
        inside = (
            (px[..., 0] > mx) & (px[..., 0] < w - mx) & (px[..., 1] > my) & (px[..., 1] < h - my)
        )
    return np.asarray(inside.all(axis=1))


def _half_planes(view: PoseView, target: F64, units: Units, y: float, *, lines: bool) -> F64:
    """(H, 3) rows ``(a, b, c)``: a centre keeps the target clear if every ``a x + b z < c``.

    Clear of the image's edges as :func:`clear_of_edges` says, for the centre ``(x, y, z)``.
    A pixel bound ``u > u0`` is ``(A_0 - u0 A_2) . (X - c) > 0`` for ``A = K R^T`` and a
    point in front of the camera: linear in the camera centre ``c``.
    """
    points, margins = _view_checks(target, units, lines=lines)
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


@dataclass(frozen=True, kw_only=True)
class _Field:
    """The lattice poses in reach that keep the target clear of the image's edges.

    Row by row of the paper (``z = j * spacing``), each row's columns ``lo..hi`` (``x = i *
    spacing``; none when ``lo > hi``): the region is convex, so each row's part is one run.
    """

    spacing: float
    y: float
    rows: Ints  # (J,) every row in reach, consecutive
    lo: Ints  # (J,)
    hi: Ints  # (J,)
    n_reach: int  # lattice poses in reach

    def count(self) -> int:
        """How many lattice poses the field holds."""
        return int(np.clip(self.hi - self.lo + 1, 0, None).sum())

    def interval(self, j: int) -> tuple[int, int]:
        """Row ``j``'s first and last column (first > last: none)."""
        k = j - int(self.rows[0]) if len(self.rows) else -1
        if not 0 <= k < len(self.rows):
            return 1, 0
        return int(self.lo[k]), int(self.hi[k])

    def centres(self, ij: Ints) -> F64:
        """(M, 3) the camera centres of lattice indices ``ij`` (M, 2)."""
        s = self.spacing
        # 0.3, not 0.30000000000000004
        x, z = np.round(ij[:, 0] * s, 10), np.round(ij[:, 1] * s, 10)
        return np.column_stack([x, np.full(len(ij), self.y), z])


def _field(first: F64, reach: Reach, planes: F64) -> _Field:
    """The lattice poses within ``reach`` of ``first`` that satisfy every half-plane."""
    s = reach.spacing
    i0, i1 = _index_range(float(first[0]), reach.radius, s)
    j0, j1 = _index_range(float(first[2]), reach.radius, s)
    rows = np.arange(j0, j1 + 1)
    z = rows * s
    x_lo, x_hi = np.full(len(rows), i0 * s), np.full(len(rows), i1 * s)
    for a, b, c in planes:  # a x + b z < c
        rhs = c - b * z
        if abs(a) <= 1e-12 * (abs(a) + abs(b)):
            x_lo = np.where(rhs > 0, x_lo, np.inf)
        elif a > 0:
            x_hi = np.minimum(x_hi, rhs / a)
        else:
            x_lo = np.maximum(x_lo, rhs / a)
    with np.errstate(invalid="ignore"):
        lo = np.clip(np.ceil(x_lo / s - 1e-9), i0, i1 + 1)
        hi = np.clip(np.floor(x_hi / s + 1e-9), i0 - 1, i1)
    lo, hi = np.nan_to_num(lo, nan=i1 + 1), np.nan_to_num(hi, nan=i0 - 1)
    return _Field(
        spacing=s, y=float(first[1]), rows=rows, lo=lo.astype(np.int64), hi=hi.astype(np.int64),
        n_reach=(i1 - i0 + 1) * (j1 - j0 + 1),
    )  # fmt: skip


def _shifted_view(template: PoseView, t_grid: F64, px: F64, *, lines: bool) -> PoseView:
    """``template``'s frames moved to the target's pixels ``px`` (2, 2) from ``t_grid``.

    The target is a dot, or two points of the finger's line (the first its centroid); the
    view's frames scatter as ``template``'s.
    """
    used = template.found
    centroids = px[0] + (template.centroids - template.centroids[used].mean(axis=0))
    if lines:
        d = px[1] - px[0]
        theta = math.degrees(math.atan2(d[1], d[0]))
        dev = wrap_theta_deg(template.thetas - template.thetas[used][0])  # lines: no arrow
        thetas = theta + (dev - dev[used].mean())
    else:
        thetas = template.thetas.copy()
    return dataclasses.replace(
        template, t_grid=np.asarray(t_grid, dtype=np.float64), centroids=centroids,
        thetas=thetas, pose=template.pose + 1,
    )  # fmt: skip


def _predicted_view(
    template: PoseView, t_grid: F64, target: F64, *, lines: bool
) -> PoseView | None:
    """The view from ``t_grid`` of the target's points, or None if none of its frames saw it.

    Where it keeps the target in view is :func:`clear_of_edges`'s question.
    """
    if not template.found.any():
        return None
    px = _project_all(target, template, np.asarray(t_grid, dtype=np.float64)[None])[0]
    return _shifted_view(template, t_grid, px, lines=lines)


def _first_ray(view: PoseView, options: EstimateOptions) -> tuple[F64, F64, F64]:
    """The first view's camera centre, its centroid's unit ray and its plane's normal.

    The normal (of its image line's plane) is a unit vector in the grid frame; NaN for a dot.
    """
    m = measure([[view, view]], options)[0][0][0]
    R = rotation_from_angles_deg(view.r_deg)
    centre = np.asarray(view.t_grid, dtype=np.float64)
    ray = grid_rays(np.asarray(m.centroid_px), view.intrinsics, R)
    if not math.isfinite(m.theta_deg):
        return centre, ray, np.full(3, np.nan)
    step = np.array([math.cos(math.radians(m.theta_deg)), math.sin(math.radians(m.theta_deg))])
    other = grid_rays(np.asarray(m.centroid_px) + 10.0 * step, view.intrinsics, R)
    normal = np.cross(ray, other)
    return centre, ray, normal / np.linalg.norm(normal)


def provisional_target(
    view: PoseView, units: Units, ground: GroundSpec | None, options: EstimateOptions
) -> F64:
    """(2, 3) a target one pose cannot locate, assumed (see the module docstring).

    The point twice, or two points of the finger's line (the first its centroid).
    """
    centre, ray, normal = _first_ray(view, options)
    depth = NOMINAL_DEPTH_IN * unit_factor(Units.IN, units)
    if ground is not None:  # the finger is above the ground: nearer than where its ray meets it
        n, offset = ground
        along = float(np.dot(n, ray))
        if along > 1e-9:
            depth = min(depth, 0.9 * (offset - float(np.dot(n, centre))) / along)
    point = centre + depth * ray
    if not np.isfinite(normal).all():
        return np.stack([point, point])
    down = np.array([0.0, 1.0, 0.0])  # y is down: the finger points at the ground
    direction = down - np.dot(down, normal) * normal
    direction /= np.linalg.norm(direction)
    return np.stack([point, point + depth * 0.02 * direction])


def located_target(
    method: Method, views: list[PoseView], point: F64, options: EstimateOptions
) -> F64:
    """(2, 3) the target as two poses or more locate it.

    The estimated point twice, or the finger's 3-D line (the planes' line, for method 2
    too) by two of its points, the first nearest the first view's centroid ray.
    """
    if not spec_of(method).uses_image_lines:
        return np.stack([point, point])
    line = SessionTrials(
        method=Method.LINE, units="", trial_ids=(1,), views=[views],
        truth=np.full((1, 2, 3), np.nan),
    )  # fmt: skip
    est = estimate_session(line, options).estimates
    p0, d = est.point[0], est.direction[0]
    centre, ray, _ = _first_ray(views[0], options)
    # The line's point nearest the centroid ray: the closest points of two lines.
    w = p0 - centre
    b, dd, e = float(ray @ d), float(d @ d), float(d @ w)
    denom = dd - b * b
    s = (b * float(ray @ w) - e) / denom if denom > 1e-12 else 0.0
    first = p0 + s * d
    scale = float(np.linalg.norm(first - centre)) * 0.02
    return np.stack([first, first + scale * d / np.linalg.norm(d)])


def _template(views: list[PoseView]) -> PoseView:
    """The view whose frames a predicted view repeats: the last that saw the target."""
    detected = [v for v in views if v.found.any()]
    return detected[-1] if detected else views[-1]


def predicted_regions(
    trials: SessionTrials, views: list[PoseView], target: F64, centres: F64,
    options: EstimateOptions,
) -> F64:  # fmt: skip
    """(K,) the trial's 95% region with one more view from each of ``centres`` (K, 3).

    NaN where the target would not be clear of the image's edges (:func:`clear_of_edges`)
    or the geometry is degenerate.
    """
    centres = np.asarray(centres, dtype=np.float64).reshape(-1, 3)
    lines = spec_of(trials.method).uses_image_lines
    template = _template(views)
    out = np.full(len(centres), np.nan)
    if not template.found.any() or not len(centres):
        return out
    clear = clear_of_edges(template, centres, target, Units(trials.units), lines=lines)
    where = np.flatnonzero(clear)
    if not where.size:
        return out
    px = _project_all(target, template, centres[where])
    rows = [
        [*views, _shifted_view(template, centres[k], px[n], lines=lines)]
        for n, k in enumerate(where)
    ]
    batch = dataclasses.replace(
        trials, trial_ids=tuple(range(1, len(rows) + 1)), views=rows,
        truth=np.repeat(trials.truth[:1], len(rows), axis=0),
    )  # fmt: skip
    out[where] = regions95(batch, options)
    return out


def _target(trial: SessionTrials, options: EstimateOptions, point: F64 | None) -> F64:
    views = trial.views[0]
    if len(views) < 2 or point is None:
        return provisional_target(views[0], Units(trial.units), trial.ground, options)
    return located_target(trial.method, views, point, options)


class _Ranker:
    """Predicts lattice poses' regions in batches, each pose once (taken ones left out)."""

    def __init__(
        self, trial: SessionTrials, views: list[PoseView], target: F64, field: _Field,
        options: EstimateOptions,
    ) -> None:  # fmt: skip
        self.trial, self.views, self.target, self.field = trial, views, target, field
        self.options = options
        self.taken = np.array([v.t_grid for v in views], dtype=np.float64)
        self.regions: dict[tuple[int, int], float] = {}
        self.unsolved = 0

    def rank(self, ij: list[tuple[int, int]], extra: F64 | None = None) -> F64:
        """Predict the poses ``ij`` not yet predicted; return the regions of ``extra``."""
        new = [p for p in dict.fromkeys(ij) if p not in self.regions]
        n_extra = 0 if extra is None else len(extra)
        if not new and not n_extra:
            return np.zeros(0)
        arr = np.array(new, dtype=np.int64).reshape(-1, 2)
        centres = self.field.centres(arr)
        gaps = np.linalg.norm(centres[:, None, :] - self.taken[None, :, :], axis=-1)
        free = (gaps > self.field.spacing / 2).all(axis=1)
        ask = centres[free] if extra is None else np.vstack([centres[free], extra])
        got = predicted_regions(self.trial, self.views, self.target, ask, self.options)
        regions = np.full(len(new), np.inf)
        found = got[: int(free.sum())]
        self.unsolved += int(np.isnan(found).sum())
        regions[free] = np.where(np.isnan(found), np.inf, found)
        self.regions.update(zip(new, regions.tolist(), strict=True))
        return np.asarray(got[int(free.sum()) :])

    def best(self, n: int, apart: int, within: float = math.inf) -> list[tuple[int, int]]:
        """Up to ``n`` best poses predicted, each ``apart`` steps from the others.

        Those after the first only if their region is within ``within`` (a share) of its.
        """
        ranked = sorted((r, p) for p, r in self.regions.items() if math.isfinite(r))
        out: list[tuple[int, int]] = []
        for r, p in ranked if n > 0 else ():
            if out and r > ranked[0][0] * (1 + within):
                break
            if all(max(abs(p[0] - q[0]), abs(p[1] - q[1])) >= apart for q in out):
                out.append(p)
            if len(out) == n:
                break
        return out


def _coarse(field: _Field, n: int) -> tuple[list[tuple[int, int]], int]:
    """At most about ``n`` poses spread over the field, and their step (in lines).

    Every chosen row's two ends among them (the best pose often lies on the field's edge);
    the whole field when it holds at most :data:`_EXHAUSTIVE`.
    """
    total = field.count()
    filled = np.flatnonzero(field.hi >= field.lo)
    if total <= _EXHAUSTIVE:
        return _sample(field, filled, 1), 1
    step = max(1, math.ceil(math.sqrt(total / n)))
    while True:
        out = _sample(field, filled, step)
        if len(out) <= n or step > total:
            return out, step
        step = math.ceil(step * 1.25)


def _sample(field: _Field, filled: Ints, step: int) -> list[tuple[int, int]]:
    """The field's poses on every ``step``-th line, with the two ends of each row taken."""
    chosen = filled[(field.rows[filled] % step == 0)]
    if filled.size:
        chosen = np.union1d(chosen, [filled[0], filled[-1]])
    out: list[tuple[int, int]] = []
    for k in chosen:
        j, a, b = int(field.rows[k]), int(field.lo[k]), int(field.hi[k])
        first = -(-a // step) * step  # the first multiple of step from a
        out += [(i, j) for i in sorted({a, b, *range(first, b + 1, step)})]
    return out


def _neighbours(field: _Field, at: tuple[int, int], h: int) -> list[tuple[int, int]]:
    """The eight poses ``h`` lines from ``at``, each moved into its row's run if outside.

    On the field's edge, also the same end of the rows up to :data:`_EDGE_WALK` steps
    away: the edge is seldom along a line of the paper, so the lattice poses along it
    stand at uneven depths inside it and their regions are uneven too.
    """
    out = []
    for dj in (-h, 0, h):
        lo, hi = field.interval(at[1] + dj)
        if lo > hi:
            continue
        for di in (-h, 0, h):
            p = (min(max(at[0] + di, lo), hi), at[1] + dj)
            if (di or dj) and p != at:
                out.append(p)
    lo, hi = field.interval(at[1])
    walk = range(2, _EDGE_WALK + 1) if at[0] in (lo, hi) else range(0)
    for dj in [d * h for k in walk for d in (-k, k)]:
        a, b = field.interval(at[1] + dj)
        if a <= b:
            out.append((a if at[0] == lo else b, at[1] + dj))
    return out


def _refine(ranker: _Ranker, seeds: list[tuple[int, int]], step: int) -> None:
    """A pattern search from each seed, on the paper's lines.

    To the best of its eight neighbours while one is better, else half the step, until a
    step of one line finds none better or the neighbours' regions are flat (:data:`_FLAT`).
    """
    at = list(dict.fromkeys(seeds))
    steps = [max(1, step // 2) if step > 1 else 0 for _ in at]
    for _ in range(_MAX_ROUNDS):
        active = [k for k, h in enumerate(steps) if h >= 1]
        if not active:
            return
        asked = {k: _neighbours(ranker.field, at[k], steps[k]) for k in active}
        ranker.rank([p for ps in asked.values() for p in ps])
        for k in active:
            here = ranker.regions[at[k]]
            better = min(asked[k], key=ranker.regions.__getitem__, default=None)
            if better is not None and ranker.regions[better] < here:
                at[k] = better
                continue
            around = [ranker.regions[p] for p in asked[k]]
            flat = all(abs(r - here) <= _FLAT * here for r in around)
            steps[k] = 0 if flat else steps[k] // 2


@dataclass(frozen=True, kw_only=True)
class _Found:
    centre: F64
    region: float
    thesis_t: F64
    thesis_region: float
    n_candidates: int
    left_out: tuple[tuple[str, int], ...]
    n_predicted: int


def _taken_in(field: _Field, taken: F64) -> int:
    """How many of the field's poses lie within half a spacing of a pose ``taken``."""
    s, near = field.spacing, set()
    for t in taken:
        for i in (math.floor(t[0] / s), math.ceil(t[0] / s)):
            for j in (math.floor(t[2] / s), math.ceil(t[2] / s)):
                lo, hi = field.interval(j)
                gap = math.dist((i * s, field.y, j * s), tuple(t))
                if lo <= i <= hi and gap <= s / 2:
                    near.add((i, j))
    return len(near)


def _best(
    trial: SessionTrials, views: list[PoseView], target: F64, reach: Reach,
    options: EstimateOptions, *, coarse: int = COARSE_CANDIDATES, seeds: int = _SEEDS,
) -> _Found | None:  # fmt: skip
    """The best reachable centre found and its region, the thesis' move and its region.

    With them, how many lattice poses keep the target in view and how many were left out,
    and why (None: no lattice pose in reach keeps it in view and solves).
    """
    taken = np.array([v.t_grid for v in views], dtype=np.float64)
    move = np.asarray(THESIS_MOVE_IN) * unit_factor(Units.IN, Units(trial.units))
    thesis_t = taken[-1] + move
    lines = spec_of(trial.method).uses_image_lines
    planes = _half_planes(_template(views), target, Units(trial.units), float(taken[0][1]),
                          lines=lines)  # fmt: skip
    field = _field(taken[0], reach, planes)
    ranker = _Ranker(trial, views, target, field, options)
    first, step = _coarse(field, coarse)
    thesis_region = float(ranker.rank(first, thesis_t[None])[0])
    _refine(ranker, ranker.best(seeds, apart=2 * step, within=_SEED_WITHIN), step)
    picked = ranker.best(1, apart=1)
    if not picked:
        return None
    n_taken = _taken_in(field, taken)
    left_out = (
        (EDGE, field.n_reach - field.count()), (TAKEN, n_taken), (UNSOLVED, ranker.unsolved),
    )  # fmt: skip
    return _Found(
        centre=field.centres(np.array(picked))[0], region=ranker.regions[picked[0]],
        thesis_t=thesis_t, thesis_region=thesis_region,
        n_candidates=field.count() - n_taken, left_out=tuple((r, n) for r, n in left_out if n),
        n_predicted=len(ranker.regions) - n_taken + 1,
    )  # fmt: skip


def suggest(
    trial: SessionTrials,
    reach: Reach,
    options: EstimateOptions | None = None,
    *,
    point: Sequence[float] | None = None,
) -> Suggestion | None:
    """The next pose for a trial of one or more accepted poses.

    ``trial``: one trial, its views in pose order, its truth as known (NaN when none is
    typed, which a line's reported point then does without). ``point``: the trial's
    estimate with two poses or more (else its target is provisional). None when no
    reachable pose keeps the target in view.
    """
    options = options or EstimateOptions()
    views = trial.views[0]
    located = None if point is None else np.asarray(point, dtype=np.float64)
    provisional = len(views) < 2 or located is None
    found = _best(trial, views, _target(trial, options, located), reach, options)
    if found is None:
        return None
    return Suggestion(
        t_grid=_triple(found.centre),
        r_deg=_triple(views[-1].r_deg),
        predicted95=found.region,
        thesis_t_grid=_triple(found.thesis_t),
        thesis95=found.thesis_region,
        provisional=provisional,
        n_candidates=found.n_candidates,
        left_out=found.left_out,
        n_predicted=found.n_predicted,
    )


@dataclass(frozen=True, kw_only=True)
class Guidance:
    """Guidance for a recording: suggestions within ``reach``, and the stop rule.

    With ``target95``, a trial is complete once its 95% region is within it, or at
    ``max_poses``.
    """

    reach: Reach
    target95: float | None = None  # session units: the region's largest semi-axis
    max_poses: int = 6

    def __post_init__(self) -> None:
        """Refuse a target that is not a positive length, or fewer than two poses."""
        if self.target95 is not None and not (math.isfinite(self.target95) and self.target95 > 0):
            raise ValueError(f"the target precision must be > 0, got {self.target95}")
        if self.max_poses < 2:
            raise ValueError(f"max_poses must be >= 2, got {self.max_poses}")

    def describe(self, units: Units) -> str:
        """The settings in words (the session records them as a note)."""
        stop = (
            f"a trial is complete once its 95% region is within {self.target95:g} {units}, "
            if self.target95 is not None
            else "no target precision, "
        )
        return (
            f"guidance: {stop}or at {self.max_poses} poses; next poses suggested on the "
            f"{self.reach.spacing:g} {units} grid within {self.reach.radius:g} {units} of "
            "the first pose"
        )


@dataclass(frozen=True, kw_only=True)
class Advice:
    """What the recorder tells the operator after a pose is accepted."""

    complete: bool  # the trial is complete (within the target, or at max_poses)
    text: str
    region95: float  # the trial's region now (NaN: fewer than two poses)
    suggestion: Suggestion | None = None
    more_poses: int | None = None  # predicted poses still needed (None: none predicted)


def advise(
    trial: SessionTrials,
    guidance: Guidance,
    options: EstimateOptions | None = None,
    *,
    point: Sequence[float] | None = None,
    region95: float = math.nan,
) -> Advice:
    """After an accepted pose: complete, or the next pose and how many more are predicted.

    ``region95`` and ``point``: the trial's result now (its live result), NaN and None
    with one pose.
    """
    options = options or EstimateOptions()
    views, units, target95 = trial.views[0], Units(trial.units), guidance.target95
    n = len(views)
    if target95 is not None and n >= 2 and region95 <= target95:
        return Advice(complete=True, region95=region95, text=(
            f"95% within {region95:.3g} {units} <= {target95:g}: trial complete"))  # fmt: skip
    if n >= guidance.max_poses:
        within = f"; 95% within {region95:.3g} {units}" if math.isfinite(region95) else ""
        beyond = f" > {target95:g}" if target95 is not None and math.isfinite(region95) else ""
        return Advice(complete=True, region95=region95, text=(
            f"{n} poses, the most for a trial: trial complete{within}{beyond}"))  # fmt: skip
    suggestion = suggest(trial, guidance.reach, options, point=point)
    if suggestion is None:
        text = (
            "no pose on the grid within reach keeps the target clear of the image's edge "
            "and solves the trial: choose the next pose yourself"
        )
        return Advice(complete=False, region95=region95, text=text)
    more = None
    horizon = min(guidance.max_poses, n + LOOKAHEAD_POSES)  # the prediction's cost is bounded
    if target95 is not None:
        located = None if point is None else np.asarray(point, dtype=np.float64)
        more = _more_poses(trial, guidance, options, _target(trial, options, located),
                           suggestion, horizon)  # fmt: skip
    said = suggestion.text(units)
    if target95 is not None:
        said += (
            f"; {more} more pose(s) predicted to reach {target95:g} {units}"
            if more is not None
            else f"; {target95:g} {units} is not predicted within {horizon} poses"
        )
    return Advice(
        complete=False, text=said, region95=region95, suggestion=suggestion, more_poses=more
    )


def _more_poses(
    trial: SessionTrials, guidance: Guidance, options: EstimateOptions, target: F64,
    first: Suggestion, horizon: int,
) -> int | None:  # fmt: skip
    """How many more poses the suggestions, one after the other, are predicted to need.

    To reach the target precision; None: not within ``horizon`` poses. Each pose ahead is
    searched more coarsely than the suggestion (:data:`_LOOKAHEAD_COARSE`, one seed): a
    count, not a pose to take.
    """
    assert guidance.target95 is not None
    views = list(trial.views[0][:1] if first.provisional else trial.views[0])
    lines = spec_of(trial.method).uses_image_lines
    step, centre, region = 1, np.asarray(first.t_grid), first.predicted95
    while len(trial.views[0]) + step <= horizon:
        if region <= guidance.target95:
            return step
        view = _predicted_view(views[-1], centre, target, lines=lines)
        found = None if view is None else _best(
            trial, [*views, view], target, guidance.reach, options,
            coarse=_LOOKAHEAD_COARSE, seeds=0,
        )  # fmt: skip
        if view is None or found is None:
            return None
        views.append(view)
        centre, region = found.centre, found.region
        step += 1
    return None


def _triple(v: F64) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))
