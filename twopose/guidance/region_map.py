"""The map for the operator: every reachable pose's predicted value over the grid paper.

The suggestion (:mod:`twopose.guidance.advice`) is one pose; an operator who cannot reach it (a
cable, the table's edge) needs the good ones near it. The map shows, for each cell of the
grid paper about the trial's first pose, what one more pose there would give: the trial's
predicted 95% region (:func:`twopose.guidance.prediction.predicted_regions`), or with one pose,
whose target's depth is not known yet, the worst regret over the depths weighed (the
measure the first suggestion minimises, :mod:`twopose.guidance.first_pose`). It says why a cell has
none: it would put the target near the image's edge or over known clutter, it is a pose
already taken, or the trial would not solve from it.

The map is the suggestion's first pass (:func:`survey`): its cells are predicted in one
batch and the search refines from them (:func:`twopose.guidance.search.search`, ``known``), so
the suggestion is never worse than a cell the operator sees: the map's best is the
suggestion. Its cost is bounded whatever the paper and the reach: the cells are the paper's
lines every ``step`` lines (the sub-lattice through the first pose,
:meth:`twopose.guidance.search.Field.cells`), ``step`` the least that leaves at most
:data:`MAP_POSES` cells in view. It covers the part of
the reach worth seeing: where the field in view is larger than the map, a coarse sample of
it first finds the poses within :data:`FOCUS` times the best value, and the map covers
those (and the poses taken); far behind the target the regions are many times the best,
all one colour.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64, Ints
from twopose.guidance.paper import REASONS, Reach
from twopose.guidance.search import (
    COARSE_CANDIDATES,
    Blocked,
    Field,
    Known,
    Predict,
    coarse_sample,
    sub_axis,
)
from twopose.values.bounds import shown
from twopose.values.units import Units

__all__ = ["FOCUS", "MAP_POSES", "REASONS", "RegionMap", "Survey", "survey"]

#: The most cells of a map in view (one batch; its cost is measured by
#: ``benchmarks/bench_suggest.py``): about 16 by 10 on the console's canvas.
MAP_POSES = 160
#: The map covers the poses whose value is within this factor of the best the coarse
#: sample found: the colour scale's end (beyond it every cell has one colour).
FOCUS = 2.0
#: A map covers at most this many times :data:`MAP_POSES` cells (in view or not): the part
#: of its box in view is convex, so its bounding box is at most about twice its area.
_EXTENT = 4
_PREDICTED, _EDGE, _TAKEN, _UNSOLVED, _CLUTTER = range(len(REASONS))


@dataclass(frozen=True, kw_only=True)
class Survey:
    """The map's cells predicted, before the search refines from them."""

    x: F64  # (I,) the cells' x (session units)
    z: F64  # (J,) the cells' z
    poses: F64  # (J, I, 3) each cell's pose: its centre, or the pose in view in it nearest
    step: int  # the paper's lines per cell
    values: F64  # (J, I) the value predicted at each cell's pose (NaN: none)
    reason: Ints  # (J, I) why none: an index into REASONS (0: predicted)
    extra: F64  # (E,) the values of the poses asked beside the lattice (the thesis' move)
    known: Known  # every pose predicted (cells and the coarse sample): the search's start
    n_reach: int  # lattice poses in reach
    n_in_view: int  # of those, the ones that keep the target clear of the image's edges


def survey(
    value: Predict, field: Field, reach: Reach, taken: F64, *, extra: F64 | None = None,
    blocked: Blocked | None = None, max_poses: int = MAP_POSES,
) -> Survey:  # fmt: skip
    """The map's cells over ``field`` predicted by ``value`` (see the module docstring).

    ``taken`` (N, 3): the trial's poses (hatched, never predicted); ``blocked``: which poses
    are over clutter; ``extra`` (E, 3): poses off the lattice predicted with the cells.
    """
    taken = np.asarray(taken, dtype=np.float64).reshape(-1, 3)
    extra = np.zeros((0, 3)) if extra is None else np.asarray(extra, dtype=np.float64)
    s = reach.spacing
    taken_ij = np.round(taken[:, [0, 2]] / s).astype(np.int64)
    known: Known = {}
    box = field.box()
    if box is not None and field.count() > max_poses:
        box, extra_values = _focus(value, field, taken, extra, blocked, known)
    else:
        extra_values = None
    i0, i1, j0, j1 = reach.box(taken[0])
    if box is None:
        box = (i0, i1, j0, j1)
    box = (
        max(i0, min(box[0], *taken_ij[:, 0])), min(i1, max(box[1], *taken_ij[:, 0])),
        max(j0, min(box[2], *taken_ij[:, 1])), min(j1, max(box[3], *taken_ij[:, 1])),
    )  # fmt: skip
    part = field.clipped(box)
    origin = (int(taken_ij[0, 0]), int(taken_ij[0, 1]))
    step = part.stride(origin, box, max_poses, extent=_EXTENT)
    while True:  # the cells on the field's edge count too
        ii = sub_axis(box[0], box[1], origin[0], step)
        jj = sub_axis(box[2], box[3], origin[1], step)
        cell_i, cell_j, has = part.cells(ii, jj, step)
        if has.sum() <= max_poses:
            break
        step = max(step + 1, math.ceil(step * 1.1))
    ij = np.column_stack([cell_i.ravel(), cell_j.ravel()])
    poses = field.centres(ij)
    values, reason = _predict_cells(value, poses, ij, has.ravel(), taken, s, blocked, known)
    ask_extra = extra_values is None and len(extra)
    extra_values = value(extra) if ask_extra else extra_values
    return Survey(
        x=np.round(ii * s, 10), z=np.round(jj * s, 10), poses=poses.reshape((*has.shape, 3)),
        step=step, values=values.reshape(has.shape), reason=reason.reshape(has.shape),
        extra=np.zeros(0) if extra_values is None else np.asarray(extra_values),
        known=known, n_reach=field.n_reach, n_in_view=field.count(),
    )  # fmt: skip


def _focus(
    value: Predict, field: Field, taken: F64, extra: F64, blocked: Blocked | None, known: Known
) -> tuple[tuple[int, int, int, int], F64]:
    """The index box of the poses worth mapping, from a coarse sample of ``field``.

    The sample's poses within :data:`FOCUS` times its best, a sample step about them; the
    whole field's box when none solves. Also the ``extra`` poses' values (one batch).
    """
    sample, step = coarse_sample(field, COARSE_CANDIDATES)
    ij = np.array(sample, dtype=np.int64).reshape(-1, 2)
    centres = field.centres(ij)
    free = np.ones(len(ij), dtype=bool)
    got, _ = _predict_cells(value, centres, ij, free, taken, field.spacing, blocked, known)
    extra_values = value(extra) if len(extra) else np.zeros(0)
    box = field.box()
    assert box is not None
    solved = np.isfinite(got)
    if not solved.any():
        return box, extra_values
    good = ij[solved & (got <= FOCUS * got[solved].min())]
    pad = (step + 1) // 2  # half the sample's step: where a good pose between samples may lie
    focus = (
        max(box[0], int(good[:, 0].min()) - pad), min(box[1], int(good[:, 0].max()) + pad),
        max(box[2], int(good[:, 1].min()) - pad), min(box[3], int(good[:, 1].max()) + pad),
    )  # fmt: skip
    return focus, extra_values


def _predict_cells(
    value: Predict, poses: F64, ij: Ints, has: np.ndarray, taken: F64, spacing: float,
    blocked: Blocked | None, known: Known,
) -> tuple[F64, Ints]:  # fmt: skip
    """(M,) each cell's value and reason; its poses added to ``known``."""
    gaps = np.linalg.norm(poses[:, None, :] - taken[None, :, :], axis=-1)
    is_taken = (gaps <= spacing / 2).any(axis=1)
    reason = np.where(~has, _EDGE, np.where(is_taken, _TAKEN, _PREDICTED))
    values = np.full(len(poses), np.nan)
    done = np.zeros(len(poses), dtype=bool)
    for k in np.flatnonzero(reason == _PREDICTED):  # met in the coarse sample: not again
        got = known.get((int(ij[k, 0]), int(ij[k, 1])))
        if got is not None:
            values[k], reason[k], done[k] = got[0], REASONS.index(got[1]), True
    ask = np.flatnonzero((reason == _PREDICTED) & ~done)
    if blocked is not None and ask.size:
        over = blocked(poses[ask])
        reason[ask[over]] = _CLUTTER
        ask = ask[~over]
    if ask.size:
        values[ask] = value(poses[ask])
        reason[ask[np.isnan(values[ask])]] = _UNSOLVED
    for k in np.flatnonzero(has & (reason != _TAKEN)):
        known[(int(ij[k, 0]), int(ij[k, 1]))] = (float(values[k]), REASONS[reason[k]])
    return values, reason


@dataclass(frozen=True, kw_only=True)
class RegionMap:
    """What one more pose from each cell of the paper would give the trial.

    Cells are centred on the paper's lines every ``step`` lines (``cell`` session units
    apart), rows along z, columns along x; each is predicted at its pose (``poses``). The
    value is the predicted 95% region (session units), or with one pose (``regret``) the
    worst regret over the depths weighed along the first view's ray (``depth_range``): the
    pose's region over each depth's best, the largest.
    """

    units: Units
    x: F64  # (I,) the cells' x (session units)
    z: F64  # (J,) the cells' z
    poses: F64  # (J, I, 3) each cell's pose
    cell: float  # a cell's side: step * spacing (session units)
    step: int  # the paper's lines per cell
    values: F64  # (J, I) the value (NaN where none)
    reason: Ints  # (J, I) why none: an index into REASONS (0: predicted)
    taken: F64  # (N, 3) the trial's poses
    suggested: F64 | None  # (3,) the suggestion's pose (the search's pick), if any
    suggested_value: float  # its value (NaN: none)
    n_reach: int  # lattice poses in reach
    n_in_view: int  # of those, the ones that keep the target clear of the image's edges
    regret: bool = False  # one pose: the values are worst regrets over the depths
    #: One pose: the nearest and farthest depth weighed along the first view's ray.
    depth_range: tuple[float, float] | None = None

    @classmethod
    def of(
        cls, cells: Survey, units: Units, reach: Reach, taken: F64, suggested: F64 | None,
        suggested_value: float, *, depth_range: tuple[float, float] | None = None,
    ) -> RegionMap:  # fmt: skip
        """The map of a survey, with the suggestion the search refined from it."""
        return cls(
            units=units, x=cells.x, z=cells.z, poses=cells.poses,
            cell=cells.step * reach.spacing,
            step=cells.step, values=cells.values, reason=cells.reason, taken=taken,
            suggested=suggested, suggested_value=suggested_value, n_reach=cells.n_reach,
            n_in_view=cells.n_in_view, regret=depth_range is not None, depth_range=depth_range,
        )  # fmt: skip

    def candidates(self) -> tuple[F64, F64]:
        """(M, 3) every pose with a value, (M,) its value: the cells, then the suggestion."""
        finite = np.isfinite(self.values)
        centres, values = self.poses[finite], self.values[finite]
        if self.suggested is not None and math.isfinite(self.suggested_value):
            centres = np.vstack([centres, self.suggested[None]])
            values = np.append(values, self.suggested_value)
        return centres, values

    def best(self) -> tuple[F64, float] | None:
        """The pose of least value (a cell or the suggestion); None: none solves."""
        top = self.n_best(1)
        return top[0] if top else None

    def n_best(self, n: int = 3) -> list[tuple[F64, float]]:
        """Up to ``n`` best poses, best first, each 2.5 cells or more from the others.

        Along x or z, where the map allows (else the next best fill the list); the
        suggestion first when it ties with a cell (the search refined from the cells).
        """
        centres, values = self.candidates()
        suggested = len(values) - 1 if self.suggested is not None and len(values) else -1
        order = sorted(range(len(values)), key=lambda k: (values[k], k != suggested, k))
        picked: list[int] = []
        for k in order:
            if len(picked) == n:
                break
            gaps = [np.abs(centres[k] - centres[p])[[0, 2]].max() for p in picked]
            if all(g >= 2.5 * self.cell for g in gaps):
                picked.append(k)
        picked += [k for k in order if k not in picked][: max(0, n - len(picked))]
        picked.sort(key=order.index)
        return [(centres[k], float(values[k])) for k in picked]

    def value_text(self, value: float) -> str:
        """A cell's value in words."""
        if self.regret:
            return f"regret {max(value - 1.0, 0.0):.0%} at its worst depth"
        return f"within {value:.3g} {self.units}"

    def best_lines(self, n: int = 3) -> list[str]:
        """The ``n`` best poses for the operator, one line each ([] when none solves)."""
        top = self.n_best(n)
        if not top:
            return []
        what = "predicted 95% region"
        if self.regret and self.depth_range is not None:
            near, far = (shown(round(d, 2)) for d in self.depth_range)
            what = f"worst regret for a target {near}-{far} {self.units} along the first ray"
        lines = [f"the {len(top)} best poses of the map ({what}):"]
        for centre, value in top:
            x, y, z = (shown(float(v)) for v in centre)
            mark = ""
            if self.suggested is not None and np.allclose(centre, self.suggested):
                mark = " (the suggestion)"
            lines.append(f"  x {x}, y {y}, z {z} {self.units}: {self.value_text(value)}{mark}")
        return lines

    def to_json(self) -> dict[str, object]:
        """What the browser console draws: the cells, the best, the colour scale's ends."""
        finite = self.values[np.isfinite(self.values)]
        best = self.best()
        low = best[1] if best is not None else math.nan
        # The scale spans the good poses: from the best to the worse of FOCUS times it and
        # the 90th percentile, the cells beyond it drawn in its last colour.
        high = float(min(np.percentile(finite, 90), FOCUS * low)) if finite.size else math.nan
        n_predicted = int(np.isin(self.reason, [_PREDICTED, _UNSOLVED]).sum())
        return {
            "units": self.units,
            "label": self.label(),
            "note": (
                f"{'a cell a line' if self.step == 1 else f'a cell every {self.step} lines'}: "
                f"{n_predicted} predicted of the {self.n_in_view} poses in view"
            ),
            "scale_text": [self._end_text(low, "best"), self._end_text(max(high, low), "or more")],
            "x": self.x.tolist(),
            "z": self.z.tolist(),
            "cell": self.cell,
            "step": self.step,
            "values": [[_rounded(v) for v in row] for row in self.values.tolist()],
            "reason": self.reason.tolist(),
            "reasons": list(REASONS),
            "measure": "regret" if self.regret else "region",
            "scale": [_rounded(low), _rounded(max(high, low))],
            "best": None if best is None else self._pose_json(best),
            "top": [self._pose_json(p) for p in self.n_best(3)],
            "taken": self.taken[:, [0, 2]].tolist(),
            "suggested": None if self.suggested is None else [float(v) for v in self.suggested],
            "n_reach": self.n_reach,
            "n_in_view": self.n_in_view,
            "depth_range": None if self.depth_range is None else list(self.depth_range),
            "n_predicted": n_predicted,
        }

    def label(self) -> str:
        """What the map's values are, briefly (its title)."""
        if self.regret and self.depth_range is not None:
            near, far = self.depth_range
            return f"worst regret, a target {near:.3g}-{far:.3g} {self.units} away"
        return f"predicted 95% region ({self.units})"

    def _end_text(self, value: float, end: str) -> str:
        """One end of the colour scale in words."""
        if not math.isfinite(value):
            return ""
        text = f"+{max(value - 1.0, 0.0):.0%}" if self.regret else f"{value:.3g} {self.units}"
        return f"{text} (best)" if end == "best" else f"{text} {end}"

    def _pose_json(self, pose: tuple[F64, float]) -> dict[str, object]:
        return {
            "t_grid": [float(v) for v in pose[0]],
            "value": _rounded(pose[1]),
            "text": self.value_text(pose[1]),
        }


def _rounded(value: float) -> float | None:
    """Four significant digits (what a colour can show), None for NaN (JSON has none)."""
    return float(f"{value:.4g}") if math.isfinite(value) else None
