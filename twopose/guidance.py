"""Where to put the laptop next, and when a trial is precise enough (issue 36).

The trial's predicted 95% region is the one the analysis will report: its poses' views
solved and propagated by :func:`twopose.session_estimate.estimate_session` (pixel scatter,
typed-translation resolution, the calibration's sigma) and reported by the analysis' rule
(:func:`twopose.truth.reported`), the 95% ellipsoid's largest semi-axis (``semiaxis95``).

A candidate next pose is a pose on the grid paper within reach
(:mod:`twopose.paper_search`: which poses keep the target clear of the image's edges, and
the coarse-to-fine search over them), the angles the last pose's. Its view is predicted by
projecting the target as the trial's poses locate it: the point (method 1) or the finger's
3-D line (the fixed line, method 2: the planes' line). Its frames scatter as the last
pose's did. Each batch of candidates is one vectorized estimate (:func:`predicted_regions`).

With one pose the target cannot be located yet (one ray, or one plane). The suggestion is
then the move that best conditions the next intersection for a *provisional* target on the
first view's ray (its centroid's), wherever along it the scene allows
(:mod:`twopose.first_pose`: the pose of least worst regret over the depths, its predicted
region a range), or at the operator's taped distance; for the finger, the provisional line
is the one in the view's plane that points most steeply down. It says so.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64
from twopose.bounds import DEFAULT_MIN_GAIN, shown
from twopose.detect import wrap_theta_deg
from twopose.estimate import EstimateOptions, PoseView
from twopose.first_pose import (
    OTHER_DEPTHS_MARGIN,
    RANGE_SLACK,
    FirstPick,
    assumed_depth,
    first_depths,
    first_ray,
    minimax_pick,
    provisional_target,
)
from twopose.methods import Method, spec_of
from twopose.paper_search import (
    COARSE_CANDIDATES,
    EDGE,
    SEEDS,
    TAKEN,
    UNSOLVED,
    Found,
    Reach,
    clear_of_edges,
    field_in_view,
    half_planes,
    project,
    search,
)
from twopose.session_estimate import SessionTrials, estimate_session
from twopose.truth import reported
from twopose.uncertainty import uncertainty_columns
from twopose.units import Units, unit_factor

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
    "predicted_regions",
    "regions95",
    "suggest",
    "target_of",
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
    #: One pose: the least and the most predicted region over the depths weighed (None:
    #: the target was located).
    predicted95_range: tuple[float, float] | None = None
    #: One pose: the nearest and farthest depth weighed along the first view's ray
    #: (session units; one depth twice when taped).
    depth_range: tuple[float, float] | None = None
    taped: bool = False  # one pose: the depth is the operator's taped distance

    def region_text(self, units: Units) -> str:
        """The predicted region in words: a range over the depths with one pose."""
        if self.predicted95_range is None or self.depth_range is None:
            return f"predicted 95% within {self.predicted95:.3g} {units}"
        lo, hi = self.predicted95_range
        near, far = self.depth_range
        if self.taped:
            taped = f"for the target taped at {shown(near)} {units}"
            return f"predicted 95% within {self.predicted95:.3g} {units} {taped}"
        return (
            f"predicted 95% within {lo:.3g}-{hi:.3g} {units} for a target "
            f"{shown(round(near, 2))}-{shown(round(far, 2))} {units} away"
        )

    def text(self, units: Units) -> str:
        """One line for the operator."""
        x, y, z = self.t_grid
        line = f"next pose: x {shown(x)}, y {shown(y)}, z {shown(z)} {units} "
        line += f"({self.region_text(units)}"
        if math.isfinite(self.thesis95):
            moved = ", ".join(shown(v) for v in self.thesis_t_grid)
            line += f"; the thesis' move to {moved} would give {self.thesis95:.3g}"
        line += ")"
        if self.provisional:
            line += (
                "; one pose cannot locate the target yet: this move best conditions the "
                "next intersection wherever along the first view's ray the target is"
                if not self.taped
                else "; one pose cannot locate the target yet: this move best conditions "
                "the next intersection for the taped distance"
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
            "predicted95_range": self.predicted95_range and list(self.predicted95_range),
            "depth_range": self.depth_range and list(self.depth_range),
            "taped": self.taped,
        }


def regions95(trials: SessionTrials, options: EstimateOptions) -> F64:
    """(T,) each trial's 95% region as the analysis reports it (NaN: not solved)."""
    estimate = estimate_session(trials, options, line_fits=False)  # the thesis' line's region
    rep = reported(estimate)
    regions = uncertainty_columns(rep.error, rep.cov)["semiaxis95"]
    return np.where(estimate.estimates.status == "ok", regions, np.nan)


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
    px = project(target, template, np.asarray(t_grid, dtype=np.float64)[None])[0]
    return _shifted_view(template, t_grid, px, lines=lines)


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
    centre, ray, _ = first_ray(views[0], options)
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
    options: EstimateOptions, *, margin: float = 1.0,
) -> F64:  # fmt: skip
    """(K,) the trial's 95% region with one more view from each of ``centres`` (K, 3).

    NaN where the target would not be clear of the image's edges (:func:`clear_of_edges`,
    its margins times ``margin``) or the geometry is degenerate.
    """
    centres = np.asarray(centres, dtype=np.float64).reshape(-1, 3)
    lines = spec_of(trials.method).uses_image_lines
    template = _template(views)
    out = np.full(len(centres), np.nan)
    if not template.found.any() or not len(centres):
        return out
    clear = clear_of_edges(
        template, centres, target, Units(trials.units), lines=lines, margin=margin
    )
    where = np.flatnonzero(clear)
    if not where.size:
        return out
    px = project(target, template, centres[where])
    rows = [
        [*views, _shifted_view(template, centres[k], px[n], lines=lines)]
        for n, k in enumerate(where)
    ]
    if options.noise.factor is None and options.noise.test_redundancy:
        # A predicted view has no noise of its own: the batch's candidates never estimate a
        # variance factor (the recorder fixes the session's: trial_result.guidance_options).
        options = dataclasses.replace(
            options, noise=dataclasses.replace(options.noise, test_redundancy=False)
        )
    batch = dataclasses.replace(
        trials, trial_ids=tuple(range(1, len(rows) + 1)), views=rows,
        truth=np.repeat(trials.truth[:1], len(rows), axis=0),
    )  # fmt: skip
    out[where] = regions95(batch, options)
    return out


def target_of(
    trial: SessionTrials, options: EstimateOptions, point: F64 | None, *,
    target_distance: float | None = None,
) -> F64:  # fmt: skip
    """(2, 3) the trial's target as guidance uses it.

    With two poses or more and the trial's estimate ``point``: the target they locate
    (:func:`located_target`). With one pose (or no estimate): the provisional target on the
    first view's ray at the depth the suggestion's single figures assume (``predicted95``:
    the taped ``target_distance``, session units, or the middle of the scene's range).
    """
    views = trial.views[0]
    if len(views) < 2 or point is None:
        units = Units(trial.units)
        depths = first_depths(views[0], units, trial.ground, options, target_distance)
        return provisional_target(views[0], units, trial.ground, options, assumed_depth(depths))
    return located_target(trial.method, views, point, options)


def _best(
    trial: SessionTrials, views: list[PoseView], target: F64, reach: Reach,
    options: EstimateOptions, *, coarse: int = COARSE_CANDIDATES, seeds: int = SEEDS,
) -> tuple[Found, F64] | None:  # fmt: skip
    """The best reachable pose found (:func:`twopose.paper_search.search`), the thesis' move.

    The move's region is the search's first extra region (None: no lattice pose in reach
    keeps the target in view and solves).
    """
    taken = np.array([v.t_grid for v in views], dtype=np.float64)
    units = Units(trial.units)
    thesis_t = _thesis_move(taken, units)
    lines = spec_of(trial.method).uses_image_lines
    planes = half_planes(_template(views), target, units, float(taken[0][1]), lines=lines)
    field = field_in_view(taken[0], reach, planes)

    def predict(centres: F64) -> F64:
        return predicted_regions(trial, views, target, centres, options)

    found = search(predict, field, taken, extra=thesis_t[None], coarse=coarse, seeds=seeds)
    return None if found is None else (found, thesis_t)


def _thesis_move(taken: F64, units: Units) -> F64:
    """(3,) the last pose moved by the thesis' move, rounded as the lattice's poses are.

    Shown to the operator: 1.2, not 1.2000000000000002.
    """
    moved = taken[-1] + np.asarray(THESIS_MOVE_IN) * unit_factor(Units.IN, units)
    return np.asarray(np.round(moved, 10), dtype=np.float64)


def suggest(
    trial: SessionTrials,
    reach: Reach,
    options: EstimateOptions | None = None,
    *,
    point: Sequence[float] | None = None,
    target_distance: float | None = None,
) -> Suggestion | None:
    """The next pose for a trial of one or more accepted poses.

    ``trial``: one trial, its views in pose order, its truth as known (NaN when none is
    typed, which a line's reported point then does without). ``point``: the trial's
    estimate with two poses or more (else its target is provisional: the pose for every
    depth the scene allows, :mod:`twopose.first_pose`, or for ``target_distance``, the
    taped distance from the first pose's camera, session units). None when no reachable
    pose keeps the target in view.
    """
    options = options or EstimateOptions()
    views = trial.views[0]
    located = None if point is None else np.asarray(point, dtype=np.float64)
    if len(views) < 2 or located is None:
        return _first_suggestion(trial, reach, options, target_distance)
    best = _best(trial, views, target_of(trial, options, located), reach, options)
    if best is None:
        return None
    found, thesis_t = best
    return Suggestion(
        t_grid=_triple(found.centre),
        r_deg=_triple(views[-1].r_deg),
        predicted95=found.region,
        thesis_t_grid=_triple(thesis_t),
        thesis95=float(found.extra_regions[0]),
        provisional=False,
        n_candidates=found.n_candidates,
        left_out=found.left_out,
        n_predicted=found.n_predicted,
    )


def _first_pick(
    trial: SessionTrials, reach: Reach, options: EstimateOptions, depths: F64, *,
    coarse: int = COARSE_CANDIDATES,
) -> FirstPick | None:  # fmt: skip
    """The pose for a target at any of ``depths`` on the first ray (``coarse``: a search's)."""
    views, units = trial.views[0], Units(trial.units)
    targets = [provisional_target(views[0], units, trial.ground, options, d) for d in depths]
    taken = np.array([v.t_grid for v in views], dtype=np.float64)
    lines = spec_of(trial.method).uses_image_lines
    # Each depth's best over the poses that keep a target there clear of the image's
    # edges; the pick keeps it in view wherever along the ray it is (by a narrower margin).
    y, seen = float(taken[0][1]), _template(views)
    margin = OTHER_DEPTHS_MARGIN if len(depths) > 1 else 1.0  # a taped depth: the full margin
    fields = [field_in_view(taken[0], reach, half_planes(seen, t, units, y, lines=lines))
              for t in targets]  # fmt: skip
    field = field_in_view(taken[0], reach, np.vstack([
        half_planes(seen, t, units, y, lines=lines, margin=margin) for t in targets
    ]))  # fmt: skip

    def predict(centres: F64, rows: list[int]) -> F64:
        return np.stack([predicted_regions(trial, views, targets[d], centres, options,
                                           margin=margin) for d in rows])  # fmt: skip

    extra = _thesis_move(taken, units)[None]
    return minimax_pick(predict, fields, field, taken, extra=extra, coarse=coarse)


def _first_suggestion(
    trial: SessionTrials, reach: Reach, options: EstimateOptions, taped: float | None
) -> Suggestion | None:
    """The suggestion of a trial whose target is not located yet (see :func:`suggest`)."""
    views, units = trial.views[0], Units(trial.units)
    depths = first_depths(views[0], units, trial.ground, options, taped)
    pick = _first_pick(trial, reach, options, depths)
    if pick is None:
        return None
    k = len(depths) // 2  # the assumed depth's (:func:`assumed_depth`)
    found, taken = pick.found, np.array([v.t_grid for v in views], dtype=np.float64)
    solved = pick.regions[np.isfinite(pick.regions)]
    return Suggestion(
        t_grid=_triple(found.centre), r_deg=_triple(views[-1].r_deg),
        predicted95=float(pick.regions[k]), thesis_t_grid=_triple(_thesis_move(taken, units)),
        thesis95=float(pick.extra_regions[k, 0]), provisional=True,
        n_candidates=found.n_candidates, left_out=found.left_out, n_predicted=pick.n_predicted,
        predicted95_range=(float(solved.min()) * (1 - RANGE_SLACK),
                           float(solved.max()) * (1 + RANGE_SLACK)) if solved.size else None,
        depth_range=(float(depths[0]), float(depths[-1])), taped=taped is not None,
    )  # fmt: skip


@dataclass(frozen=True, kw_only=True)
class Guidance:
    """Guidance for a recording: suggestions within ``reach``, and the stop rule.

    With ``target95``, a trial is complete once its 95% region is within it; with
    ``min_gain``, once the next pose would shrink its region by less than that share (the
    information-gain stop, as Kalibr's ``--mi-tol``); at ``max_poses`` in any case.
    ``target_distance``: the operator's taped distance from the first pose's camera to the
    target (session units), which the first suggestion then assumes (else every depth the
    scene allows, :mod:`twopose.first_pose`).
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
        return Advice(complete=True, region95=region95, reason=STOP_TARGET, text=(
            f"95% within {region95:.3g} {units} <= {shown(target95)}: trial complete"))  # fmt: skip
    if n >= guidance.max_poses:
        within = f"; 95% within {region95:.3g} {units}" if math.isfinite(region95) else ""
        beyond = f" > {shown(target95)}" if target95 is not None and math.isfinite(region95) else ""
        return Advice(complete=True, region95=region95, reason=STOP_MAX_POSES, text=(
            f"{n} poses, the most for a trial: trial complete{within}{beyond}"))  # fmt: skip
    suggestion = suggest(
        trial, guidance.reach, options, point=point, target_distance=guidance.target_distance
    )
    if suggestion is None:
        text = (
            "no pose on the grid within reach keeps the target clear of the image's edge "
            "and solves the trial: choose the next pose yourself"
        )
        return Advice(complete=False, region95=region95, text=text)
    gain = 1.0 - suggestion.predicted95 / region95 if math.isfinite(region95) else math.nan
    if guidance.min_gain is not None and not suggestion.provisional and gain < guidance.min_gain:
        return Advice(complete=True, region95=region95, reason=STOP_MIN_GAIN, text=(
            f"the next pose would shrink the 95% region by only {max(gain, 0.0):.1%} (to "
            f"{suggestion.predicted95:.3g} {units} from {region95:.3g}; less than "
            f"{guidance.min_gain:.0%}, the least gain): trial complete"))  # fmt: skip
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
        best = None if view is None else _best(
            trial, [*views, view], target, guidance.reach, options,
            coarse=_LOOKAHEAD_COARSE, seeds=0,
        )  # fmt: skip
        if view is None or best is None:
            return None
        views.append(view)
        centre, region = best[0].centre, best[0].region
        step += 1
    return None


def _triple(v: F64) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))
