"""The predicted 95% region of every reachable pose: a map over the grid paper (issue 46).

The suggestion (:mod:`twopose.guidance`) is one pose; an operator who cannot reach it (a
cable, the table's edge) needs the good ones near it. The map predicts the trial's 95%
region with one more pose from each cell of the grid paper about the trial's first pose,
exactly as the suggestion's search does (:func:`twopose.guidance.predicted_regions`, the
target as guidance uses it, :func:`twopose.guidance.target_of`), and says why a cell has no
region: it would put the target near the image's edge, it is a pose already taken, or the
trial would not solve from it.

Its cost is bounded whatever the paper and the reach: the cells are the paper's lines every
``step`` lines (the sub-lattice through the first pose), ``step`` the least that leaves at
most :data:`MAP_POSES` cells keeping the target in view (counted exactly on
:class:`twopose.paper_search.Field`), and every one of them is predicted in one batch. The
map covers the part of the reach the target stays in view from (and the trial's poses).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64, Ints
from twopose.bounds import shown
from twopose.estimate import EstimateOptions, PoseView
from twopose.guidance import Suggestion, predicted_regions, target_of
from twopose.methods import spec_of
from twopose.paper_search import (
    EDGE,
    TAKEN,
    UNSOLVED,
    Field,
    Reach,
    clear_of_edges,
    field_in_view,
    half_planes,
)
from twopose.session_estimate import SessionTrials
from twopose.units import Units

__all__ = ["MAP_POSES", "REASONS", "RegionMap", "region_map"]

#: The most cells a map predicts (one batch; its cost is measured by
#: ``benchmarks/bench_suggest.py``).
MAP_POSES = 240
#: A map covers at most this many times :data:`MAP_POSES` cells (in view or not): the part
#: of the reach in view is convex, so its bounding box is at most about twice its area.
_EXTENT = 4
#: Why a cell has no region (its ``reason``, an index into this): none (0, predicted), near
#: the image's edge, taken, not solved (the words of :mod:`twopose.paper_search`).
REASONS = ("", EDGE, TAKEN, UNSOLVED)
_PREDICTED, _EDGE, _TAKEN, _UNSOLVED = range(4)


@dataclass(frozen=True, kw_only=True)
class RegionMap:
    """The trial's predicted 95% region with one more pose from each cell of the paper.

    Cells are centred on the paper's lines every ``step`` lines (``cell`` session units
    apart), rows along z, columns along x; each is predicted at its pose (``poses``).
    """

    units: str
    x: F64  # (I,) the cells' x (session units)
    z: F64  # (J,) the cells' z
    poses: F64  # (J, I, 3) each cell's pose: its centre, or the pose in view in it nearest
    cell: float  # a cell's side: step * spacing (session units)
    step: int  # the paper's lines per cell
    region95: F64  # (J, I) the predicted region (session units); NaN where none
    reason: Ints  # (J, I) why none: an index into REASONS (0: predicted)
    taken: F64  # (N, 3) the trial's poses
    suggested: F64 | None  # (3,) the suggestion's pose (its search's pick), if any
    suggested95: float  # its predicted region (NaN: none)
    n_reach: int  # lattice poses in reach
    n_in_view: int  # of those, the ones that keep the target clear of the image's edges
    #: With one pose: how far along the first view's ray the target is assumed (session
    #: units; the suggestion is chosen for every depth the scene allows); NaN: located.
    assumed_depth: float = math.nan

    def candidates(self) -> tuple[F64, F64]:
        """(M, 3) every pose with a region, (M,) its region: the cells, then the suggestion."""
        finite = np.isfinite(self.region95)
        centres, regions = self.poses[finite], self.region95[finite]
        if self.suggested is not None and math.isfinite(self.suggested95):
            centres = np.vstack([centres, self.suggested[None]])
            regions = np.append(regions, self.suggested95)
        return centres, regions

    def best(self) -> tuple[F64, float] | None:
        """The pose of least predicted region (a cell or the suggestion); None: none solves."""
        top = self.n_best(1)
        return top[0] if top else None

    def n_best(self, n: int = 3) -> list[tuple[F64, float]]:
        """Up to ``n`` best poses, best first, none next to another where the map allows.

        Next to: within one cell along x and z. Should too few poses be apart, the next
        best fill the list.
        """
        centres, regions = self.candidates()
        order = np.lexsort((np.arange(len(regions)), regions))  # ties: the cells' order
        picked: list[int] = []
        for k in order:
            if len(picked) == n:
                break
            gaps = [np.abs(centres[k] - centres[p])[[0, 2]].max() for p in picked]
            if all(g > 1.5 * self.cell for g in gaps):
                picked.append(int(k))
        rest = [int(k) for k in order if k not in picked]
        picked += rest[: max(0, n - len(picked))]
        picked.sort(key=lambda k: (regions[k], k))
        return [(centres[k], float(regions[k])) for k in picked]

    def best_lines(self, n: int = 3) -> list[str]:
        """The ``n`` best poses for the operator, one line each ([] when none solves)."""
        top = self.n_best(n)
        if not top:
            return []
        units = self.units
        assumed = ""
        if math.isfinite(self.assumed_depth):
            assumed = f", the target assumed {self.assumed_depth:.3g} {units} along the first ray"
        lines = [f"the {len(top)} best poses of the map (predicted 95% region{assumed}):"]
        for centre, region in top:
            x, y, z = (shown(float(v)) for v in centre)
            mark = ""
            if self.suggested is not None and np.allclose(centre, self.suggested):
                mark = " (the suggestion)"
            lines.append(f"  x {x}, y {y}, z {z} {units}: within {region:.3g} {units}{mark}")
        return lines

    def to_json(self) -> dict[str, object]:
        """What the browser console draws: the cells, the best, the colour scale's ends."""
        finite = self.region95[np.isfinite(self.region95)]
        best = self.best()
        low = best[1] if best is not None else math.nan
        # The scale spans the good poses: from the best to the worse of twice it and the
        # 90th percentile, the cells beyond it drawn in its last colour.
        high = float(min(np.percentile(finite, 90), 2.0 * low)) if finite.size else math.nan
        regions = [[_rounded(v) for v in row] for row in self.region95.tolist()]
        return {
            "units": self.units,
            "x": self.x.tolist(),
            "z": self.z.tolist(),
            "cell": self.cell,
            "step": self.step,
            "region95": regions,
            "reason": self.reason.tolist(),
            "reasons": list(REASONS),
            "scale": [_rounded(low), _rounded(max(high, low))],
            "best": None if best is None else _pose_json(best),
            "top": [_pose_json(p) for p in self.n_best(3)],
            "taken": self.taken[:, [0, 2]].tolist(),
            "n_reach": self.n_reach,
            "n_in_view": self.n_in_view,
            "assumed_depth": _rounded(self.assumed_depth),
            "n_predicted": int(
                np.sum(self.reason == _PREDICTED) + np.sum(self.reason == _UNSOLVED)
            ),
        }


def _rounded(value: float) -> float | None:
    """Four significant digits (what a colour can show), None for NaN (JSON has none)."""
    return float(f"{value:.4g}") if math.isfinite(value) else None


def _pose_json(pose: tuple[F64, float]) -> dict[str, object]:
    return {"t_grid": [float(v) for v in pose[0]], "region95": _rounded(pose[1])}


def _seen(views: list[PoseView]) -> PoseView:
    """The view a predicted view repeats (:func:`twopose.guidance.predicted_regions`'s)."""
    detected = [v for v in views if v.found.any()]
    return detected[-1] if detected else views[-1]


def _in_view_count(field: Field, origin: tuple[int, int], step: int) -> int:
    """How many of the field's poses lie on the sub-lattice every ``step`` lines."""
    a, b = origin
    rows = (field.rows - b) % step == 0
    lo, hi = field.lo[rows], field.hi[rows]
    n = np.floor_divide(hi - a, step) - np.floor_divide(lo - a - 1, step)
    return int(np.clip(np.where(hi >= lo, n, 0), 0, None).sum())


def _extent(field: Field, reach: Reach, first: F64, taken_ij: Ints) -> tuple[int, int, int, int]:
    """The lattice's index box the map covers: the field's and the poses', within reach."""
    s = reach.spacing
    i0 = math.ceil((first[0] - reach.radius) / s - 1e-9)
    i1 = math.floor((first[0] + reach.radius) / s + 1e-9)
    j0 = math.ceil((first[2] - reach.radius) / s - 1e-9)
    j1 = math.floor((first[2] + reach.radius) / s + 1e-9)
    filled = field.hi >= field.lo
    if not filled.any():
        return i0, i1, j0, j1
    i_lo = min(int(field.lo[filled].min()), *taken_ij[:, 0])
    i_hi = max(int(field.hi[filled].max()), *taken_ij[:, 0])
    j_lo = min(int(field.rows[filled].min()), *taken_ij[:, 1])
    j_hi = max(int(field.rows[filled].max()), *taken_ij[:, 1])
    return max(i0, i_lo), min(i1, i_hi), max(j0, j_lo), min(j1, j_hi)


def _stride(field: Field, origin: tuple[int, int], box: tuple[int, int, int, int], cap: int) -> int:
    """The least step that leaves at most ``cap`` cells in view and ``_EXTENT * cap`` in all."""
    i_lo, i_hi, j_lo, j_hi = box
    area = (i_hi - i_lo + 1) * (j_hi - j_lo + 1)
    step = max(1, math.ceil(math.sqrt(max(field.count(), area / _EXTENT) / cap)))
    while _in_view_count(field, origin, step) > cap or (
        math.ceil((i_hi - i_lo + 1) / step) * math.ceil((j_hi - j_lo + 1) / step) > _EXTENT * cap
    ):
        step = max(step + 1, math.ceil(step * 1.1))
    return step


def _axis(lo: int, hi: int, origin: int, step: int) -> Ints:
    """The sub-lattice's indices (``origin`` plus multiples of ``step``) from lo to hi."""
    first = origin + math.ceil((lo - origin) / step) * step
    last = origin + math.floor((hi - origin) / step) * step
    return np.arange(first, last + 1, step, dtype=np.int64)


def _cells(field: Field, ii: Ints, jj: Ints, step: int) -> tuple[Ints, Ints, np.ndarray]:
    """(J, I) each cell's pose, as lattice indices, and whether it has one in view.

    A cell's pose is its centre if it keeps the target in view, else the lattice pose in
    view within the cell nearest its centre: the best pose often lies on the edge of what
    is in view, which the cells' centres would miss.
    """
    before = step // 2  # the cell spans centre - before .. centre - before + step - 1
    dj = np.array(sorted(range(-before, step - before), key=abs))  # (S,) the centre's first
    rows = jj[None, :] + dj[:, None]  # (S, J)
    k = rows - int(field.rows[0])
    inside = (k >= 0) & (k < len(field.rows))
    kk = np.clip(k, 0, len(field.rows) - 1)
    lo = np.where(inside, field.lo[kk], 1)[:, :, None]  # (S, J, 1)
    hi = np.where(inside, field.hi[kk], 0)[:, :, None]
    a = np.maximum(lo, ii[None, None, :] - before)  # (S, J, I): the row's part in the cell
    b = np.minimum(hi, ii[None, None, :] - before + step - 1)
    pose_i = np.clip(ii[None, None, :], a, b)
    gap = np.where(a <= b, np.abs(pose_i - ii) + np.abs(dj)[:, None, None], np.iinfo(np.int64).max)
    nearest = np.argmin(gap, axis=0)  # (J, I): of equals, the row nearest the centre's
    has = np.take_along_axis(gap, nearest[None], axis=0)[0] < np.iinfo(np.int64).max
    cell_i = np.take_along_axis(pose_i, nearest[None], axis=0)[0]
    cell_j = jj[:, None] + dj[nearest]
    return cell_i, cell_j, has


def region_map(
    trial: SessionTrials, reach: Reach, options: EstimateOptions | None = None, *,
    point: F64 | None = None, suggestion: Suggestion | None = None, max_poses: int = MAP_POSES,
    target_distance: float | None = None,
) -> RegionMap:  # fmt: skip
    """The map of a trial of one or more accepted poses (see the module docstring).

    ``trial``, ``point``, ``target_distance``: as :func:`twopose.guidance.suggest` takes
    them; ``suggestion``: its pick, drawn on the map and among its best (its region was
    predicted alike).
    """
    options = options or EstimateOptions()
    views = trial.views[0]
    units = Units(trial.units)
    located = None if point is None else np.asarray(point, np.float64)
    target = target_of(trial, options, located, target_distance=target_distance)
    lines = spec_of(trial.method).uses_image_lines
    taken = np.array([v.t_grid for v in views], dtype=np.float64)
    s = reach.spacing
    planes = half_planes(_seen(views), target, units, float(taken[0][1]), lines=lines)
    field = field_in_view(taken[0], reach, planes)
    origin = (round(float(taken[0][0]) / s), round(float(taken[0][2]) / s))
    taken_ij = np.round(taken[:, [0, 2]] / s).astype(np.int64)
    box = _extent(field, reach, taken[0], taken_ij)
    step = _stride(field, origin, box, max_poses)
    while True:  # the cells on the field's edge count too
        ii = _axis(box[0], box[1], origin[0], step)
        jj = _axis(box[2], box[3], origin[1], step)
        cell_i, cell_j, has = _cells(field, ii, jj, step)
        if has.sum() <= max_poses:
            break
        step = max(step + 1, math.ceil(step * 1.1))
    poses = field.centres(np.column_stack([cell_i.ravel(), cell_j.ravel()]))
    gaps = np.linalg.norm(poses[:, None, :] - taken[None, :, :], axis=-1)
    is_taken = (gaps <= s / 2).any(axis=1).reshape(has.shape)
    reason = np.where(~has, _EDGE, np.where(is_taken, _TAKEN, _PREDICTED))
    ask = np.flatnonzero((reason == _PREDICTED).ravel())
    regions = np.full(reason.size, np.nan)
    if ask.size:
        regions[ask] = predicted_regions(trial, views, target, poses[ask], options)
        # The field and the projection may disagree on a pose at the edge by a rounding.
        clear = clear_of_edges(_seen(views), poses[ask], target, units, lines=lines)
        flat = reason.ravel()
        flat[ask] = np.where(clear, np.where(np.isnan(regions[ask]), _UNSOLVED, _PREDICTED), _EDGE)
        reason = flat.reshape(reason.shape)
    return RegionMap(
        units=str(units), x=np.round(ii * s, 10), z=np.round(jj * s, 10),
        poses=poses.reshape((*has.shape, 3)), cell=step * s, step=step,
        region95=regions.reshape(reason.shape), reason=reason,
        taken=taken, suggested=None if suggestion is None else np.asarray(suggestion.t_grid),
        suggested95=math.nan if suggestion is None else suggestion.predicted95,
        n_reach=field.n_reach, n_in_view=field.count(),
        assumed_depth=float(np.linalg.norm(target[0] - taken[0]))
        if len(views) < 2 or located is None else math.nan,
    )  # fmt: skip
