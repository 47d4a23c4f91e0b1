"""The lattice of poses on the grid paper, and the search on it for the best pose.

The poses that keep the target in view (:class:`Field`, counted exactly however fine the
paper and wide the reach: the region is convex, so each row of the paper holds one run of
them) are not all predicted. A first pass predicts a
sample of them: either the map's cells (:mod:`twopose.guidance.region_map`, given as ``known``, so
that the suggestion is never worse than a cell the operator sees), or about
:data:`COARSE_CANDIDATES` poses spread over the field (every row's two ends among them,
where the best pose usually lies). A pattern search on the paper's own lines then refines
from the best few, halving its step down to one line. Each pass is one batch, one call of
the caller's prediction (:func:`twopose.guidance.prediction.predicted_regions`, one vectorized
estimate). A pose over known clutter (:mod:`twopose.detect.clutter`, the caller's ``blocked``) is
never predicted. ``benchmarks/bench_suggest.py`` measures the cost and how far the pick's
region is from the whole lattice's best.

The lattice lives here because the search and the map (its cells are the lattice's
sub-lattice every ``step`` lines, :meth:`Field.cells`) both walk it: each question the
search asks of a row or a cell is answered in this file.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Iterator
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64, Bools, Ints
from twopose.guidance.paper import CLUTTER, EDGE, TAKEN, UNSOLVED, Reach

__all__ = [
    "COARSE_CANDIDATES",
    "SEEDS",
    "Blocked",
    "Field",
    "Found",
    "Known",
    "Predict",
    "PredictPairs",
    "coarse_sample",
    "field_in_view",
    "search",
    "search_together",
    "sub_axis",
    "taken_in",
]

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
#: A prediction for several searches at once: (P, 3) camera centres and (P,) the index of
#: the search each is for, to their (P,) regions.
PredictPairs = Callable[[F64, Ints], F64]
#: A lattice pose by its indices: the paper's column and row.
Pose = tuple[int, int]
#: Which poses are over known clutter: (M, 3) camera centres to (M,) booleans.
Blocked = Callable[[F64], Bools]


#: What a search knows of a pose before it starts (the map's cells): its region and why it
#: has none ("" when it has one; :data:`twopose.guidance.paper.UNSOLVED`,
#: :data:`~twopose.guidance.paper.CLUTTER`).
Known = dict[tuple[int, int], tuple[float, str]]


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

    def contains(self, ij: Ints) -> Bools:
        """(M,) whether lattice indices ``ij`` (M, 2) lie in the field."""
        ij = np.asarray(ij, dtype=np.int64).reshape(-1, 2)
        if not len(self.rows):
            return np.zeros(len(ij), dtype=bool)
        k = ij[:, 1] - int(self.rows[0])
        inside = (k >= 0) & (k < len(self.rows))
        kk = np.clip(k, 0, len(self.rows) - 1)
        return np.asarray(inside & (self.lo[kk] <= ij[:, 0]) & (ij[:, 0] <= self.hi[kk]))

    def box(self) -> tuple[int, int, int, int] | None:
        """The field's index box: first and last column, first and last row (None: empty)."""
        filled = self.hi >= self.lo
        if not filled.any():
            return None
        rows = self.rows[filled]
        return (
            int(self.lo[filled].min()), int(self.hi[filled].max()), int(rows[0]), int(rows[-1])
        )  # fmt: skip

    def clipped(self, box: tuple[int, int, int, int]) -> Field:
        """The field's poses within the index ``box`` (first, last column, first, last row)."""
        i0, i1, j0, j1 = box
        keep = (self.rows >= j0) & (self.rows <= j1)
        return Field(
            spacing=self.spacing, y=self.y, rows=self.rows[keep],
            lo=np.maximum(self.lo[keep], i0), hi=np.minimum(self.hi[keep], i1),
            n_reach=self.n_reach,
        )  # fmt: skip

    def in_sublattice(self, origin: tuple[int, int], step: int) -> int:
        """How many of the field's poses lie on the sub-lattice every ``step`` lines."""
        a, b = origin
        rows = (self.rows - b) % step == 0
        lo, hi = self.lo[rows], self.hi[rows]
        n = np.floor_divide(hi - a, step) - np.floor_divide(lo - a - 1, step)
        return int(np.clip(np.where(hi >= lo, n, 0), 0, None).sum())

    def stride(
        self, origin: tuple[int, int], box: tuple[int, int, int, int], cap: int, *, extent: int
    ) -> int:
        """The least sub-lattice step that leaves at most ``cap`` cells in the field.

        And at most ``extent * cap`` in ``box`` (the map's cells,
        :mod:`twopose.guidance.region_map`).
        """
        i_lo, i_hi, j_lo, j_hi = box
        area = (i_hi - i_lo + 1) * (j_hi - j_lo + 1)
        step = max(1, math.ceil(math.sqrt(max(self.count(), area / extent) / cap)))
        while self.in_sublattice(origin, step) > cap or (
            math.ceil((i_hi - i_lo + 1) / step) * math.ceil((j_hi - j_lo + 1) / step) > extent * cap
        ):
            step = max(step + 1, math.ceil(step * 1.1))
        return step

    def cells(self, ii: Ints, jj: Ints, step: int) -> tuple[Ints, Ints, Bools]:
        """(J, I) each cell's pose as lattice indices, and whether it has one in the field.

        The cells are centred on columns ``ii`` and rows ``jj`` (every ``step`` lines). A
        cell's pose is its centre if that lies in the field, else the field's pose within
        the cell nearest its centre: the best pose often lies on the field's edge, which
        the cells' centres would miss. None in view when the field has no row in the box.
        """
        if not len(self.rows) or not len(ii) or not len(jj):
            shape = (len(jj), len(ii))
            cols = np.broadcast_to(ii[None, :], shape).copy()
            return cols, np.broadcast_to(jj[:, None], shape).copy(), np.zeros(shape, dtype=bool)
        before = step // 2  # the cell spans centre - before .. centre - before + step - 1
        dj = np.array(sorted(range(-before, step - before), key=abs))  # (S,) the centre's first
        rows = jj[None, :] + dj[:, None]  # (S, J)
        k = rows - int(self.rows[0])
        inside = (k >= 0) & (k < len(self.rows))
        kk = np.clip(k, 0, len(self.rows) - 1)
        lo = np.where(inside, self.lo[kk], 1)[:, :, None]  # (S, J, 1)
        hi = np.where(inside, self.hi[kk], 0)[:, :, None]
        a = np.maximum(lo, ii[None, None, :] - before)  # (S, J, I): the row's part in the cell
        b = np.minimum(hi, ii[None, None, :] - before + step - 1)
        pose_i = np.clip(ii[None, None, :], a, b)
        never = np.iinfo(np.int64).max
        gap = np.where(a <= b, np.abs(pose_i - ii) + np.abs(dj)[:, None, None], never)
        nearest = np.argmin(gap, axis=0)  # (J, I): of equals, the row nearest the centre's
        has = np.take_along_axis(gap, nearest[None], axis=0)[0] < never
        cell_i = np.take_along_axis(pose_i, nearest[None], axis=0)[0]
        cell_j = jj[:, None] + dj[nearest]
        return cell_i, cell_j, has


def field_in_view(first: F64, reach: Reach, planes: F64) -> Field:
    """The lattice poses within ``reach`` of ``first`` that satisfy every half-plane."""
    s = reach.spacing
    i0, i1, j0, j1 = reach.box(first)
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


def taken_in(field: Field, taken: F64) -> int:
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


def sub_axis(lo: int, hi: int, origin: int, step: int) -> Ints:
    """The sub-lattice's indices (``origin`` plus multiples of ``step``) in lo..hi, one at least."""
    first = origin + math.ceil((lo - origin) / step) * step
    last = origin + math.floor((hi - origin) / step) * step
    if first > last:  # a box narrower than a cell: the cell nearest its middle
        first = last = origin + round(((lo + hi) / 2 - origin) / step) * step
    return np.arange(first, last + 1, step, dtype=np.int64)


class _Ranker:
    """Predicts lattice poses' regions in batches, each pose once.

    Poses taken are never predicted, nor those over known clutter (``blocked``); a pose
    with no region ranks last (infinite), its reason kept.
    """

    def __init__(
        self, predict: Predict, field: Field, taken: F64, blocked: Blocked | None = None,
        known: Known | None = None,
    ) -> None:  # fmt: skip
        self.predict, self.field, self.taken, self.blocked = predict, field, taken, blocked
        self.regions: dict[tuple[int, int], float] = {}
        self.reasons: dict[tuple[int, int], str] = {}
        for pose, (region, reason) in (known or {}).items():
            self.regions[pose] = region if not reason and math.isfinite(region) else math.inf
            self.reasons[pose] = reason if reason or math.isfinite(region) else UNSOLVED

    def ask(self, ij: list[tuple[int, int]]) -> tuple[list[tuple[int, int]], F64]:
        """The poses of ``ij`` met for the first time that need a prediction, and their centres.

        (M, 3); the others met for the first time are booked (taken, over clutter).
        """
        new = [p for p in dict.fromkeys(ij) if p not in self.regions]
        if not new:
            return [], np.zeros((0, 3))
        centres = self.field.centres(np.array(new, dtype=np.int64).reshape(-1, 2))
        gaps = np.linalg.norm(centres[:, None, :] - self.taken[None, :, :], axis=-1)
        why = np.where((gaps > self.field.spacing / 2).all(axis=1), "", TAKEN).astype(object)
        if self.blocked is not None and (why == "").any():
            free = np.flatnonzero(why == "")
            why[free[self.blocked(centres[free])]] = CLUTTER
        for pose, reason in zip(new, why.tolist(), strict=True):
            if reason:
                self.regions[pose], self.reasons[pose] = math.inf, reason
        free = why == ""
        return [p for p, f in zip(new, free, strict=True) if f], centres[free]

    def answer(self, poses: list[tuple[int, int]], regions: F64) -> None:
        """Book the predicted ``regions`` of ``poses`` (NaN: not solved)."""
        for pose, region in zip(poses, np.asarray(regions).tolist(), strict=True):
            solved = math.isfinite(region)
            self.regions[pose] = region if solved else math.inf
            self.reasons[pose] = "" if solved else UNSOLVED

    def rank(self, ij: list[tuple[int, int]], extra: F64 | None = None) -> F64:
        """Predict the poses ``ij`` not yet predicted; return the regions of ``extra``."""
        poses, centres = self.ask(ij)
        asked = centres if extra is None else np.vstack([centres, extra])
        got = self.predict(asked) if len(asked) else np.zeros(0)
        self.answer(poses, got[: len(poses)])
        return np.asarray(got[len(poses) :])

    def count(self, reason: str) -> int:
        """How many poses met so far have no region for ``reason``."""
        return sum(1 for r in self.reasons.values() if r == reason)

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


def coarse_sample(field: Field, n: int) -> tuple[list[tuple[int, int]], int]:
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


def _refine(ranker: _Ranker, seeds: list[tuple[int, int]], step: int) -> Iterator[list[Pose]]:
    """A pattern search from each seed, on the paper's lines: yields each round's poses.

    The caller ranks them before the next round. To the best of its eight neighbours while
    one is better, else half the step, until a step of one line finds none better or the
    neighbours' regions are flat (:data:`_FLAT`).
    """
    at = list(dict.fromkeys(seeds))
    steps = [max(1, step // 2) if step > 1 else 0 for _ in at]
    for _ in range(_MAX_ROUNDS):
        active = [k for k, h in enumerate(steps) if h >= 1]
        if not active:
            return
        asked = {k: _neighbours(ranker.field, at[k], steps[k]) for k in active}
        yield [p for ps in asked.values() for p in ps]
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


def search(
    predict: Predict, field: Field, taken: F64, *, extra: F64 | None = None,
    coarse: int = COARSE_CANDIDATES, seeds: int = SEEDS, blocked: Blocked | None = None,
    known: tuple[Known, int] | None = None,
) -> Found | None:  # fmt: skip
    """The best pose of ``field`` found by ``predict``, or None if none solves.

    ``predict`` maps (M, 3) camera centres to their (M,) regions (NaN: out of view or
    unsolved); ``taken`` (N, 3) are the trial's poses, never picked again, nor the poses
    ``blocked`` says are over clutter; ``extra`` (E, 3) poses off the lattice whose regions
    are wanted too (the thesis' move), predicted with the first pass. The first pass is
    ``known`` (poses already predicted, and how many lines apart: the map's cells) or a
    coarse pass of about ``coarse`` poses; then a pattern search from its ``seeds`` best.
    """
    book, step = known if known is not None and known[0] else ({}, 1)
    ranker = _Ranker(
        predict, field, np.asarray(taken, dtype=np.float64).reshape(-1, 3), blocked, book
    )
    first, step = ([], step) if book else coarse_sample(field, coarse)
    extra_regions = ranker.rank(first, extra)
    for poses in _refine(ranker, ranker.best(seeds, apart=2 * step, within=_SEED_WITHIN), step):
        ranker.rank(poses)
    return _found(ranker, extra_regions, 0 if extra is None else len(extra))


def search_together(
    predict: PredictPairs, fields: list[Field], taken: F64, *,
    blocked: list[Blocked | None] | None = None, coarse: int = COARSE_CANDIDATES,
    seeds: int = SEEDS,
) -> list[Found | None]:  # fmt: skip
    """:func:`search` over each of ``fields`` at once, one batch a round for all of them.

    ``predict`` maps (P, 3) camera centres and (P,) the fields' indices (what each is
    predicted for: the first pose's depths) to their (P,) regions; ``blocked``: each
    field's poses over clutter (None: none known).
    """
    taken = np.asarray(taken, dtype=np.float64).reshape(-1, 3)
    checks = blocked or [None] * len(fields)
    rankers = [_Ranker(_unused, f, taken, b) for f, b in zip(fields, checks, strict=True)]
    samples = [coarse_sample(f, coarse) for f in fields]
    _rank_together(predict, rankers, [poses for poses, _ in samples])
    rounds = [
        _refine(r, r.best(seeds, apart=2 * step, within=_SEED_WITHIN), step)
        for r, (_, step) in zip(rankers, samples, strict=True)
    ]
    asked = [next(g, None) for g in rounds]
    while any(a is not None for a in asked):
        _rank_together(predict, rankers, [a or [] for a in asked])
        asked = [None if a is None else next(g, None) for g, a in zip(rounds, asked, strict=True)]
    return [_found(r, np.zeros(0), 0) for r in rankers]


def _unused(_: F64) -> F64:
    raise AssertionError("search_together predicts for its rankers")


def _rank_together(predict: PredictPairs, rankers: list[_Ranker], ij: list[list[Pose]]) -> None:
    """Rank each ranker's poses ``ij[k]`` in one call of ``predict``."""
    asked = [r.ask(poses) for r, poses in zip(rankers, ij, strict=True)]
    sizes = [len(poses) for poses, _ in asked]
    if not sum(sizes):
        return
    centres = np.vstack([c for _, c in asked])
    got = predict(centres, np.repeat(np.arange(len(rankers)), sizes))
    for r, (poses, _), part in zip(
        rankers, asked, np.split(got, np.cumsum(sizes)[:-1]), strict=True
    ):
        r.answer(poses, part)


def _found(ranker: _Ranker, extra_regions: F64, n_extra: int) -> Found | None:
    """The ranker's best pose, and what it weighed (None: none solves)."""
    field = ranker.field
    picked = ranker.best(1, apart=1)
    if not picked:
        return None
    n_taken = taken_in(field, ranker.taken)
    left_out = (
        (EDGE, field.n_reach - field.count()), (TAKEN, n_taken),
        (CLUTTER, ranker.count(CLUTTER)), (UNSOLVED, ranker.count(UNSOLVED)),
    )  # fmt: skip
    return Found(
        centre=field.centres(np.array(picked))[0], region=ranker.regions[picked[0]],
        extra_regions=extra_regions, n_candidates=field.count() - n_taken,
        left_out=tuple((r, n) for r, n in left_out if n),
        n_predicted=sum(1 for r in ranker.reasons.values() if r in ("", UNSOLVED)) + n_extra,
    )  # fmt: skip
