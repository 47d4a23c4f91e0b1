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

from twopose.arrays import F64
from twopose.bounds import shown
from twopose.camera import grid_rays, rotation_from_angles_deg
from twopose.detect import wrap_theta_deg
from twopose.estimate import EstimateOptions, GroundSpec, PoseView, measure
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
    "NOMINAL_DEPTH_IN",
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
#: Where a target seen from one pose is assumed, along its ray (the thesis' ~10 in).
NOMINAL_DEPTH_IN = 10.0
#: The prediction of how many poses are still needed searches more coarsely (no pattern
#: search) ...
_LOOKAHEAD_COARSE = 10
#: ... and looks at most this many poses ahead (its cost grows with each).
LOOKAHEAD_POSES = 4


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
            f"next pose: x {shown(x)}, y {shown(y)}, z {shown(z)} {units} "
            f"(predicted 95% within {self.predicted95:.3g} {units}"
        )
        if math.isfinite(self.thesis95):
            moved = ", ".join(shown(v) for v in self.thesis_t_grid)
            line += f"; the thesis' move to {moved} would give {self.thesis95:.3g}"
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
    px = project(target, template, centres[where])
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


def target_of(trial: SessionTrials, options: EstimateOptions, point: F64 | None) -> F64:
    """(2, 3) the trial's target as guidance uses it.

    With two poses or more and the trial's estimate ``point``: the target they locate
    (:func:`located_target`). With one pose (or no estimate): the provisional target on the
    first view's ray at the depth the suggestion assumes (:func:`provisional_target`).
    """
    views = trial.views[0]
    if len(views) < 2 or point is None:
        return provisional_target(views[0], Units(trial.units), trial.ground, options)
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
    # Rounded as the lattice's poses are (shown to the operator: 1.2, not 1.2000000000000002).
    thesis_t = np.round(taken[-1] + np.asarray(THESIS_MOVE_IN) * unit_factor(Units.IN, units), 10)
    lines = spec_of(trial.method).uses_image_lines
    planes = half_planes(_template(views), target, units, float(taken[0][1]), lines=lines)
    field = field_in_view(taken[0], reach, planes)

    def predict(centres: F64) -> F64:
        return predicted_regions(trial, views, target, centres, options)

    found = search(predict, field, taken, extra=thesis_t[None], coarse=coarse, seeds=seeds)
    return None if found is None else (found, thesis_t)


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
            f"a trial is complete once its 95% region is within {shown(self.target95)} {units}, "
            if self.target95 is not None
            else "no target precision, "
        )
        return (
            f"guidance: {stop}or at {self.max_poses} poses; next poses suggested on the "
            f"{shown(self.reach.spacing)} {units} grid within {shown(self.reach.radius)} {units} "
            "of the first pose"
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
            f"95% within {region95:.3g} {units} <= {shown(target95)}: trial complete"))  # fmt: skip
    if n >= guidance.max_poses:
        within = f"; 95% within {region95:.3g} {units}" if math.isfinite(region95) else ""
        beyond = f" > {shown(target95)}" if target95 is not None and math.isfinite(region95) else ""
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
        more = _more_poses(trial, guidance, options, target_of(trial, options, located),
                           suggestion, horizon)  # fmt: skip
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
