"""Where to put the laptop next, and when a trial is precise enough (issue 36).

A candidate next pose is a pose on the grid paper within reach (:mod:`twopose.guidance.paper`:
which poses keep the target clear of the image's edges and of known clutter), the angles
the last pose's, its region the trial's predicted 95% region with it
(:mod:`twopose.guidance.prediction`). The map's cells over the part of the paper worth seeing are
predicted first (:mod:`twopose.guidance.region_map`), then a pattern search refines from them
(:mod:`twopose.guidance.search`): the suggestion is the map's best, and the map says why the
cells without a region have none (:func:`plan_next`).

With one pose the target cannot be located yet (one ray, or one plane). The suggestion is
then the move that best conditions the next intersection for a *provisional* target on the
first view's ray (its centroid's), wherever along it the scene allows
(:mod:`twopose.guidance.first_pose`: the pose of least worst regret over the depths, its predicted
region a range, the map each cell's worst regret), or at the operator's taped distance; for
the finger, the provisional line is the one in the view's plane that points most steeply
down. It says so, and gives the thesis' move's region over the same depths.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64, Bools
from twopose.detect.clutter import Clutter, over_clutter
from twopose.guidance.first_pose import (
    OTHER_DEPTHS_MARGIN,
    RANGE_SLACK,
    first_depths,
    minimax_pick,
    provisional_target,
)
from twopose.guidance.paper import CLUTTER, Reach, half_planes
from twopose.guidance.prediction import predicted_regions, predicted_view, target_of, template_view
from twopose.guidance.region_map import RegionMap, survey
from twopose.guidance.search import Field, field_in_view, search
from twopose.guidance.suggestion import Suggestion
from twopose.solve.estimate import EstimateOptions, PoseView
from twopose.solve.session import SessionTrials
from twopose.values.bounds import DEFAULT_MIN_GAIN, shown
from twopose.values.units import Units, unit_factor

__all__ = [
    "LOOKAHEAD_POSES",
    "MIN_GAIN",
    "STOP_MAX_POSES",
    "STOP_MIN_GAIN",
    "STOP_TARGET",
    "THESIS_MOVE_IN",
    "Advice",
    "Guidance",
    "Reach",
    "Suggestion",
    "advise",
    "plan_next",
    "suggest",
]

#: The thesis' move from one pose to the next: about an inch along x (Appendix D's 1.1 in).
THESIS_MOVE_IN = (1.0, 0.0, 0.0)
#: The prediction of how many poses are still needed searches more coarsely (no pattern
#: search) ...
_LOOKAHEAD_COARSE = 10
#: ... and looks at most this many poses ahead (its cost grows with each).
LOOKAHEAD_POSES = 4
#: The information-gain stop's default least share (:attr:`Guidance.min_gain`): what
#: ``benchmarks/bench_guidance.py`` supports (docs/guidance.md says why).
MIN_GAIN = DEFAULT_MIN_GAIN


@dataclass(frozen=True, kw_only=True)
class _Trial:
    """A trial as guidance weighs it: what does not change between its candidates."""

    trial: SessionTrials
    views: list[PoseView]
    options: EstimateOptions
    clutter: Clutter | None
    reach: Reach

    @property
    def units(self) -> Units:
        return Units(self.trial.units)

    @property
    def lines(self) -> bool:
        return self.trial.spec.uses_image_lines

    @property
    def taken(self) -> F64:
        return np.array([v.t_grid for v in self.views], dtype=np.float64)

    @property
    def template(self) -> PoseView:
        return template_view(self.views)

    def thesis_move(self) -> F64:
        """(3,) the last pose moved by the thesis' move, rounded as the lattice's poses are.

        Shown to the operator: 1.2, not 1.2000000000000002.
        """
        moved = self.taken[-1] + np.asarray(THESIS_MOVE_IN) * unit_factor(Units.IN, self.units)
        return np.asarray(np.round(moved, 10), dtype=np.float64)

    def field(self, target: F64, margin: float = 1.0) -> Field:
        """The lattice poses in reach that keep ``target`` clear of the image's edges."""
        planes = half_planes(self.template, target, self.units, float(self.taken[0][1]),
                             lines=self.lines, margin=margin)  # fmt: skip
        return field_in_view(self.taken[0], self.reach, planes)

    def predict(self, target: F64, margin: float = 1.0) -> Callable[[F64], F64]:
        """The trial's region with one more pose from each of (M, 3) centres."""
        trial, views, options = self.trial, list(self.views), self.options
        return lambda c: predicted_regions(trial, views, target, c, options, margin=margin)

    def blocked(self, target: F64) -> Callable[[F64], Bools] | None:
        """Which poses would show ``target`` over the known clutter (None: none known)."""
        if self.clutter is None or not len(self.clutter):
            return None
        template, units, lines, clutter = self.template, self.units, self.lines, self.clutter
        return lambda c: over_clutter(template, c, target, units, clutter, lines=lines)


def plan_next(
    trial: SessionTrials, reach: Reach, options: EstimateOptions | None = None, *,
    point: Sequence[float] | None = None, target_distance: float | None = None,
    clutter: Clutter | None = None,
) -> tuple[Suggestion | None, RegionMap | None]:  # fmt: skip
    """The next pose for a trial of one or more accepted poses, and the map it is the best of.

    ``trial``: one trial, its views in pose order, its truth as known (NaN when none is
    typed, which a line's reported point then does without). ``point``: the trial's
    estimate with two poses or more (else its target is provisional: the pose for every
    depth the scene allows, :mod:`twopose.guidance.first_pose`, or for ``target_distance``, the
    taped distance from the first pose's camera, session units). ``clutter``: what the
    target must not be seen over (:mod:`twopose.detect.clutter`). The suggestion is None when no
    reachable pose keeps the target in view and solves; the map then says why.
    """
    t = _Trial(trial=trial, views=trial.views[0], options=options or EstimateOptions(),
               clutter=clutter, reach=reach)  # fmt: skip
    located = None if point is None else np.asarray(point, dtype=np.float64)
    if len(t.views) < 2 or located is None:
        depths = first_depths(t.views[0], t.units, trial.ground, t.options, target_distance)
        if len(depths) > 1:
            return _first_suggestion(t, depths)
        return _suggestion(t, target_of(trial, t.options, None, target_distance=target_distance),
                           depth=(float(depths[0]), target_distance is not None))  # fmt: skip
    return _suggestion(t, target_of(trial, t.options, located))


def suggest(
    trial: SessionTrials, reach: Reach, options: EstimateOptions | None = None, *,
    point: Sequence[float] | None = None, target_distance: float | None = None,
    clutter: Clutter | None = None,
) -> Suggestion | None:  # fmt: skip
    """The next pose for a trial (:func:`plan_next` without its map); None: no pose solves."""
    return plan_next(trial, reach, options, point=point, target_distance=target_distance,
                     clutter=clutter)[0]  # fmt: skip


def _suggestion(
    t: _Trial, target: F64, depth: tuple[float, bool] | None = None
) -> tuple[Suggestion | None, RegionMap]:
    """The best pose for a located target (or one at a single depth along the first ray).

    ``depth``: the one depth weighed and whether the operator taped it (None: located).
    """
    taken, thesis_t = t.taken, t.thesis_move()
    field, predict, blocked = t.field(target), t.predict(target), t.blocked(target)
    cells = survey(predict, field, t.reach, taken, extra=thesis_t[None], blocked=blocked)
    found = search(predict, field, taken, known=(cells.known, cells.step), blocked=blocked)
    region_map = RegionMap.of(
        cells,
        t.units,
        t.reach,
        taken,
        None if found is None else found.centre,
        math.nan if found is None else found.region,
    )
    if found is None:
        return None, region_map
    d = None if depth is None else depth[0]
    return Suggestion(
        t_grid=_triple(found.centre), r_deg=_triple(t.views[-1].r_deg), predicted95=found.region,
        thesis_t_grid=_triple(thesis_t), thesis95=float(cells.extra[0]),
        provisional=depth is not None, n_candidates=found.n_candidates, left_out=found.left_out,
        n_predicted=found.n_predicted,
        predicted95_range=None if d is None else (found.region, found.region),
        depth_range=None if d is None else (d, d), taped=depth is not None and depth[1],
        assumed_depth=d, clutter=_source(t, found.left_out),
    ), region_map  # fmt: skip


def _first_suggestion(t: _Trial, depths: F64) -> tuple[Suggestion | None, RegionMap | None]:
    """The suggestion of a trial whose target is not located yet (see :func:`plan_next`)."""
    view, units, ground = t.views[0], t.units, t.trial.ground
    targets = np.stack([provisional_target(view, units, ground, t.options, d) for d in depths])
    taken, margin = t.taken, OTHER_DEPTHS_MARGIN
    # Each depth's best over the poses that keep a target there clear of the image's
    # edges; the pick keeps it clear wherever along the ray it is, by the same margin.
    fields = [t.field(target, margin) for target in targets]
    y, seen = float(taken[0][1]), t.template
    every = np.vstack([half_planes(seen, target, units, y, lines=t.lines, margin=margin)
                       for target in targets])  # fmt: skip
    field = field_in_view(taken[0], t.reach, every)

    def predict(centres: F64, depth: np.ndarray) -> F64:
        return predicted_regions(t.trial, t.views, targets[depth], centres, t.options,
                                 margin=margin)  # fmt: skip

    blocked = [t.blocked(target) for target in targets]

    def blocked_at(centres: F64, d: int) -> Bools:
        check = blocked[d]
        return np.zeros(len(centres), dtype=bool) if check is None else check(centres)

    thesis_t = t.thesis_move()
    pick = minimax_pick(predict, fields, field, t.reach, taken, extra=thesis_t[None],
                        blocked_at=blocked_at if t.clutter is not None else None)  # fmt: skip
    if pick is None:
        return None, None
    k = len(depths) // 2  # the assumed depth's (:func:`twopose.guidance.first_pose.assumed_depth`)
    found = pick.found
    region_map = RegionMap.of(pick.cells, units, t.reach, taken, found.centre, found.region,
                              depth_range=(float(depths[0]), float(depths[-1])))  # fmt: skip
    solved = pick.regions[np.isfinite(pick.regions)]
    thesis = pick.extra_regions[:, 0]
    thesis = thesis[np.isfinite(thesis)]
    return Suggestion(
        t_grid=_triple(found.centre), r_deg=_triple(t.views[-1].r_deg),
        predicted95=float(pick.regions[k]), thesis_t_grid=_triple(thesis_t),
        thesis95=float(pick.extra_regions[k, 0]), provisional=True,
        n_candidates=found.n_candidates, left_out=found.left_out, n_predicted=pick.n_predicted,
        predicted95_range=(float(solved.min()) * (1 - RANGE_SLACK),
                           float(solved.max()) * (1 + RANGE_SLACK)) if solved.size else None,
        depth_range=(float(depths[0]), float(depths[-1])),
        thesis95_range=(float(thesis.min()), float(thesis.max())) if thesis.size else None,
        assumed_depth=float(depths[k]), clutter=_source(t, found.left_out),
    ), region_map  # fmt: skip


def _source(t: _Trial, left_out: tuple[tuple[str, int], ...]) -> str:
    """Where the clutter left out is known from ("" when none was left out for it)."""
    if t.clutter is None or not any(reason == CLUTTER for reason, _ in left_out):
        return ""
    return t.clutter.source


@dataclass(frozen=True, kw_only=True)
class Guidance:
    """Guidance for a recording: suggestions within ``reach``, and the stop rule.

    With ``target95``, a trial is complete once its 95% region is within it; with
    ``min_gain``, once the next pose would shrink its region by less than that share (the
    information-gain stop, as Kalibr's ``--mi-tol``); at ``max_poses`` in any case.
    ``target_distance``: the operator's taped distance from the first pose's camera to the
    target (session units), which the first suggestion then assumes (else every depth the
    scene allows, :mod:`twopose.guidance.first_pose`).
    """

    reach: Reach
    target95: float | None = None  # session units: the region's largest semi-axis
    max_poses: int = 6
    min_gain: float | None = MIN_GAIN
    target_distance: float | None = None

    def __post_init__(self) -> None:
        """Refuse a target that is not a positive length, or fewer than two poses."""
        if self.target95 is not None and not (math.isfinite(self.target95) and self.target95 > 0):
            raise ValueError(f"the target precision must be > 0, got {self.target95}")
        if self.max_poses < 2:
            raise ValueError(f"max_poses must be >= 2, got {self.max_poses}")
        if self.min_gain is not None and not 0 < self.min_gain < 1:
            raise ValueError(f"the least gain must be a share in (0, 1), got {self.min_gain}")
        d = self.target_distance
        if d is not None and not (math.isfinite(d) and d > 0):
            raise ValueError(f"the target distance must be > 0, got {d}")

    @property
    def stops(self) -> bool:
        """Whether a rule may end a trial before ``max_poses`` (a target or a least gain)."""
        return self.target95 is not None or self.min_gain is not None

    def describe(self, units: Units) -> str:
        """The settings in words (the session records them as a note)."""
        stop = (
            f"a trial is complete once its 95% region is within {shown(self.target95)} {units}, "
            if self.target95 is not None
            else "no target precision, "
        )
        if self.min_gain is not None:
            # the least gain as given (0.125, never a rounded 12%)
            stop += f"once the next pose would shrink it by less than {shown(self.min_gain)}, "
        taped = (
            f"; the target taped {shown(self.target_distance)} {units} from the first pose"
            if self.target_distance is not None
            else ""
        )
        return (
            f"guidance: {stop}or at {self.max_poses} poses; next poses suggested on the "
            f"{shown(self.reach.spacing)} {units} grid within {shown(self.reach.radius)} {units} "
            f"of the first pose{taped}"
        )


#: Why a trial is complete (:attr:`Advice.reason`): its region within the target, ...
STOP_TARGET = "target precision"
#: ... the next pose would gain less than ``min_gain``, ...
STOP_MIN_GAIN = "least gain"
#: ... or it has ``max_poses``.
STOP_MAX_POSES = "max poses"


@dataclass(frozen=True, kw_only=True)
class Advice:
    """What the recorder tells the operator after a pose is accepted."""

    complete: bool  # the trial is complete (within the target, or at max_poses)
    text: str
    region95: float  # the trial's region now (NaN: fewer than two poses)
    suggestion: Suggestion | None = None
    more_poses: int | None = None  # predicted poses still needed (None: none predicted)
    reason: str = ""  # complete: why (:data:`STOP_TARGET`, ...); "" while it is not
    #: The map the suggestion is the best of (:mod:`twopose.guidance.region_map`; None: complete).
    region_map: RegionMap | None = None


def advise(
    trial: SessionTrials, guidance: Guidance, options: EstimateOptions | None = None, *,
    point: Sequence[float] | None = None, region95: float = math.nan,
    clutter: Clutter | None = None,
) -> Advice:  # fmt: skip
    """After an accepted pose: complete, or the next pose and how many more are predicted.

    ``region95`` and ``point``: the trial's result now (its live result), NaN and None
    with one pose; ``clutter``: what the target must not be seen over.
    """
    options = options or EstimateOptions()
    views, units, target95 = trial.views[0], Units(trial.units), guidance.target95
    n = len(views)
    if target95 is not None and n >= 2 and region95 <= target95:
        return Advice(complete=True, region95=region95, reason=STOP_TARGET, text=(
            f"95% within {region95:.3g} {units} <= {shown(target95)}: trial complete"))  # fmt: skip
    if n >= guidance.max_poses:
        return Advice(complete=True, region95=region95, reason=STOP_MAX_POSES, text=(
            f"{n} poses, the most for a trial: trial complete{_missed(guidance, region95, units)}"
        ))  # fmt: skip
    suggestion, region_map = plan_next(trial, guidance.reach, options, point=point,
                                       target_distance=guidance.target_distance,
                                       clutter=clutter)  # fmt: skip
    if suggestion is None:
        text = (
            "no pose on the grid within reach keeps the target clear of the image's edge "
            "and solves the trial: choose the next pose yourself"
        )
        return Advice(complete=False, region95=region95, text=text, region_map=region_map)
    gain = 1.0 - suggestion.predicted95 / region95 if math.isfinite(region95) else math.nan
    if guidance.min_gain is not None and not suggestion.provisional and gain < guidance.min_gain:
        return Advice(complete=True, region95=region95, reason=STOP_MIN_GAIN, text=(
            f"the next pose would shrink the 95% region by only {max(gain, 0.0):.1%} (to "
            f"{suggestion.predicted95:.3g} {units} from {region95:.3g}; less than "
            f"{guidance.min_gain:.0%}, the least gain): trial complete"
            f"{_missed(guidance, region95, units)}"))  # fmt: skip
    more = None
    horizon = min(guidance.max_poses, n + LOOKAHEAD_POSES)  # the prediction's cost is bounded
    if target95 is not None:
        located = None if point is None else np.asarray(point, dtype=np.float64)
        target = target_of(trial, options, located, target_distance=guidance.target_distance)
        more = _more_poses(trial, guidance, options, target, suggestion, horizon)
    said = suggestion.text(units)
    if target95 is not None:
        said += (
            f"; {more} more pose(s) predicted to reach {shown(target95)} {units}"
            if more is not None
            else f"; {shown(target95)} {units} is not predicted within {horizon} poses"
        )
    return Advice(complete=False, text=said, region95=region95, suggestion=suggestion,
                  more_poses=more, region_map=region_map)  # fmt: skip


def _missed(guidance: Guidance, region95: float, units: Units) -> str:
    """A trial complete short of its target precision says so ("" when none was set)."""
    if not math.isfinite(region95):
        return ""
    if guidance.target95 is None:
        return f"; 95% within {region95:.3g} {units}"
    return (
        f"; 95% within {region95:.3g} {units} > {shown(guidance.target95)}: the target "
        "precision was not reached"
    )


def _more_poses(
    trial: SessionTrials, guidance: Guidance, options: EstimateOptions, target: F64,
    first: Suggestion, horizon: int,
) -> int | None:  # fmt: skip
    """How many more poses the suggestions, one after the other, are predicted to need.

    To reach the target precision; None: not within ``horizon`` poses. Each pose ahead is
    searched more coarsely than the suggestion (:data:`_LOOKAHEAD_COARSE` poses, no pattern
    search): a count, not a pose to take.
    """
    assert guidance.target95 is not None
    views = list(trial.views[0][:1] if first.provisional else trial.views[0])
    lines = trial.spec.uses_image_lines
    step, centre, region = 1, np.asarray(first.t_grid), first.predicted95
    while len(trial.views[0]) + step <= horizon:
        if region <= guidance.target95:
            return step
        view = predicted_view(views[-1], centre, target, lines=lines)
        if view is None:
            return None
        views.append(view)
        t = _Trial(trial=trial, views=views, options=options, clutter=None, reach=guidance.reach)
        field = t.field(target)

        best = search(t.predict(target), field, t.taken, coarse=_LOOKAHEAD_COARSE, seeds=0)
        if best is None:
            return None
        centre, region = best.centre, best.region
        step += 1
    return None


def _triple(v: F64) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))
