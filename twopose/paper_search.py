"""Where on the grid paper the next pose may go, and the search for the best of them.

A candidate next pose is a camera centre on the grid paper's lines (the multiples of the
spacing, whatever the first pose) within :class:`Reach` of the trial's first pose (the
laptop stays on the table: y is the first pose's). A candidate is left out when it would
put the target near the image's edge (the centroid within :data:`IN_VIEW_MARGIN` of the
image's size, or either end of the finger within :data:`END_MARGIN`: a blob at the edge is
lost or merges with clutter), when it is a pose already taken, or when the trial would not
solve from it.

The poses that keep the target in view form a convex region of the table (the reach's
square cut by one half-plane per image edge and point, :func:`half_planes`), so they are
counted exactly, row by row of the paper (:class:`Field`), however fine the paper and wide
the reach. Their regions are not all predicted (:func:`search`): a coarse pass over the
field (about :data:`COARSE_CANDIDATES` poses, every row's two ends among them, where the
best pose usually lies), then a pattern search on the paper's own lines from the best few,
halving its step down to one line. Each pass is one batch, one call of the caller's
prediction (:func:`twopose.guidance.predicted_regions`, one vectorized estimate).
``benchmarks/bench_suggest.py`` measures its cost and how far its pick's region is from
the whole lattice's best.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64, Bools, Ints
from twopose.camera import rotation_from_angles_deg
from twopose.estimate import PoseView
from twopose.solve import projection_matrices
from twopose.targets import FINGER_LENGTH
from twopose.units import Units, unit_factor

__all__ = [
    "COARSE_CANDIDATES",
    "EDGE",
    "END_MARGIN",
    "IN_VIEW_MARGIN",
    "SEEDS",
    "TAKEN",
    "UNSOLVED",
    "Field",
    "Found",
    "Predict",
    "Reach",
    "clear_of_edges",
    "field_in_view",
    "half_planes",
    "lattice",
    "project",
    "search",
]

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
SEEDS = 2
_SEED_WITHIN = 0.05
#: The pattern search stops where its neighbours' regions differ by less than this share:
#: a finer step could gain no more than about that.
_FLAT = 0.002
#: On the field's edge, the pattern search also looks this many steps along it.
_EDGE_WALK = 4
#: The pattern search's rounds, at most (each one batch).
_MAX_ROUNDS = 40
#: A prediction: (M, 3) camera centres to their (M,) regions (NaN: out of view, unsolved).
Predict = Callable[[F64], F64]
#: Why a lattice pose in reach was not suggested (:attr:`Suggestion.left_out`): too near
#: the image's edge.
EDGE = "near the image's edge"
#: ... already taken.
TAKEN = "taken"
#: ... its prediction did not solve.
UNSOLVED = "not solved"


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
    clear by less at the other depths: :data:`twopose.first_pose.OTHER_DEPTHS_MARGIN`).
    """
    points, margins = _view_checks(target, units, lines=lines)
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
    points, margins = _view_checks(target, units, lines=lines)
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


@dataclass(frozen=True, kw_only=True)
class Field:
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


def field_in_view(first: F64, reach: Reach, planes: F64) -> Field:
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
    return Field(
        spacing=s, y=float(first[1]), rows=rows, lo=lo.astype(np.int64), hi=hi.astype(np.int64),
        n_reach=(i1 - i0 + 1) * (j1 - j0 + 1),
    )  # fmt: skip


class _Ranker:
    """Predicts lattice poses' regions in batches, each pose once (taken ones left out)."""

    def __init__(self, predict: Predict, field: Field, taken: F64) -> None:
        self.predict, self.field, self.taken = predict, field, taken
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
        got = self.predict(ask)
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


def _coarse(field: Field, n: int) -> tuple[list[tuple[int, int]], int]:
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


def _sample(field: Field, filled: Ints, step: int) -> list[tuple[int, int]]:
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


def _neighbours(field: Field, at: tuple[int, int], h: int) -> list[tuple[int, int]]:
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
class Found:
    """The search's pick, its region, and what it weighed."""

    centre: F64  # (3,) the pose picked
    region: float  # its predicted region (session units)
    extra_regions: F64  # the regions of the poses asked beside the lattice (NaN: none)
    n_candidates: int  # lattice poses in reach that keep the target in view, not taken
    left_out: tuple[tuple[str, int], ...]  # lattice poses in reach left out, by reason
    n_predicted: int  # poses whose region was predicted (the search's cost)


def _taken_in(field: Field, taken: F64) -> int:
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


def search(
    predict: Predict, field: Field, taken: F64, *, extra: F64 | None = None,
    coarse: int = COARSE_CANDIDATES, seeds: int = SEEDS,
) -> Found | None:  # fmt: skip
    """The best pose of ``field`` found by ``predict``, or None if none solves.

    ``predict`` maps (M, 3) camera centres to their (M,) regions (NaN: out of view or
    unsolved); ``taken`` (N, 3) are the trial's poses, never picked again; ``extra``
    (E, 3) poses off the lattice whose regions are wanted too (the thesis' move), predicted
    with the coarse pass. A coarse pass of about ``coarse`` poses, then a pattern search
    from its ``seeds`` best.
    """
    ranker = _Ranker(predict, field, np.asarray(taken, dtype=np.float64).reshape(-1, 3))
    first, step = _coarse(field, coarse)
    extra_regions = ranker.rank(first, extra)
    _refine(ranker, ranker.best(seeds, apart=2 * step, within=_SEED_WITHIN), step)
    picked = ranker.best(1, apart=1)
    if not picked:
        return None
    n_taken = _taken_in(field, ranker.taken)
    left_out = (
        (EDGE, field.n_reach - field.count()), (TAKEN, n_taken), (UNSOLVED, ranker.unsolved),
    )  # fmt: skip
    return Found(
        centre=field.centres(np.array(picked))[0], region=ranker.regions[picked[0]],
        extra_regions=extra_regions, n_candidates=field.count() - n_taken,
        left_out=tuple((r, n) for r, n in left_out if n),
        n_predicted=len(ranker.regions) - n_taken + (0 if extra is None else len(extra)),
    )  # fmt: skip
