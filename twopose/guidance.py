"""Where to put the laptop next, and when a trial is precise enough (issue 36).

The trial's predicted 95% region is the one the analysis will report: its poses' views
solved and propagated by :func:`twopose.session_estimate.estimate_session` (pixel scatter,
typed-translation resolution, the calibration's sigma) and reported by the analysis' rule
(:func:`twopose.truth.reported`), the 95% ellipsoid's largest semi-axis (``semiaxis95``).

A candidate next pose is a camera centre on the grid's lattice within :class:`Reach` of the
trial's first pose (the laptop stays on the table: y and the angles are the last pose's).
Its view is predicted by projecting the target as the trial's poses locate it: the point
(method 1) or the finger's 3-D line (the fixed line, method 2: the planes' line). Its
frames scatter as the last pose's did. Every candidate, and the thesis' default move (the
last pose plus about an inch along x), is one trial of a batch: one vectorized estimate
ranks them all.

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
from twopose.camera import grid_rays, rotation_from_angles_deg
from twopose.detect import wrap_theta_deg
from twopose.estimate import EstimateOptions, GroundSpec, PoseView, measure
from twopose.methods import Method, spec_of
from twopose.session_estimate import SessionTrials, estimate_session
from twopose.solve import projection_matrices
from twopose.truth import reported
from twopose.uncertainty import uncertainty_columns
from twopose.units import Units, unit_factor

__all__ = [
    "NOMINAL_DEPTH_IN",
    "THESIS_MOVE_IN",
    "Advice",
    "Guidance",
    "Reach",
    "Suggestion",
    "advise",
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
_IN_VIEW_MARGIN = 0.2


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
    n_candidates: int

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
        return line

    def to_json(self) -> dict[str, object]:
        """What the browser console shows (its marker and the values the pose form takes)."""
        return {
            "t_grid": list(self.t_grid),
            "r_deg": list(self.r_deg),
            "predicted95": self.predicted95,
            "thesis_t_grid": list(self.thesis_t_grid),
            "thesis95": self.thesis95,
            "provisional": self.provisional,
        }


def lattice(first_t: F64, reach: Reach, taken: F64) -> F64:
    """(K, 3) reachable camera centres, less those taken.

    The grid's lattice in x and z within the reach of ``first_t``, at its height, less
    those within half a spacing of a pose ``taken``.
    """
    steps = np.arange(-math.floor(reach.radius / reach.spacing + 1e-9),
                      math.floor(reach.radius / reach.spacing + 1e-9) + 1)  # fmt: skip
    dx, dz = np.meshgrid(steps * reach.spacing, steps * reach.spacing, indexing="ij")
    points = np.column_stack([dx.ravel(), np.zeros(dx.size), dz.ravel()]) + first_t
    gaps = np.linalg.norm(points[:, None, :] - np.asarray(taken)[None, :, :], axis=-1)
    return np.asarray(points[(gaps > reach.spacing / 2).all(axis=1)])


def regions95(trials: SessionTrials, options: EstimateOptions) -> F64:
    """(T,) each trial's 95% region as the analysis reports it (NaN: not solved)."""
    estimate = estimate_session(trials, options, line_fits=False)  # the thesis' line's region
    rep = reported(estimate)
    regions = uncertainty_columns(rep.error, rep.cov)["semiaxis95"]
    return np.where(estimate.estimates.status == "ok", regions, np.nan)


def _project(points: F64, view: PoseView, t_grid: F64) -> F64:
    """(M, 2) pixels of grid points seen by ``view``'s camera moved to ``t_grid``."""
    R = rotation_from_angles_deg(view.r_deg)
    P = projection_matrices(view.intrinsics, R, t_grid)
    h = np.column_stack([points, np.ones(len(points))]) @ P.T
    ahead = h[:, 2:3] > 0  # a point behind the camera has no pixel
    return np.asarray(np.where(ahead, h[:, :2] / np.where(ahead, h[:, 2:3], 1.0), np.nan))


def _in_view(px: F64, view: PoseView) -> bool:
    w, h = view.width_height
    mx, my = _IN_VIEW_MARGIN * w, _IN_VIEW_MARGIN * h
    return bool(np.isfinite(px).all() and (px[:, 0] > mx).all() and (px[:, 0] < w - mx).all()
                and (px[:, 1] > my).all() and (px[:, 1] < h - my).all())  # fmt: skip


def _predicted_view(
    template: PoseView, t_grid: F64, target: F64, *, lines: bool
) -> PoseView | None:
    """The view from ``t_grid`` of the target's points, or None if it would leave the image.

    The target is a dot, or two points of the finger's line (the first its centroid); the
    view's frames scatter as ``template``'s.
    """
    px = _project(target, template, t_grid)
    if not _in_view(px[:1], template):  # the centroid; the second point only orients it
        return None
    centroid = px[0]
    used = template.found
    if not used.any():
        return None
    centroids = centroid + (template.centroids - template.centroids[used].mean(axis=0))
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


def predicted_regions(
    trials: SessionTrials, views: list[PoseView], target: F64, centres: F64,
    options: EstimateOptions,
) -> F64:  # fmt: skip
    """(K,) the trial's 95% region with one more view from each of ``centres`` (K, 3).

    NaN where the target would leave the image or the geometry is degenerate.
    """
    lines = spec_of(trials.method).uses_image_lines
    rows, where = [], []
    detected = [v for v in views if v.found.any()]
    template = detected[-1] if detected else views[-1]  # frames that scatter as a pose's do
    for k, t in enumerate(centres):
        view = _predicted_view(template, t, target, lines=lines)
        if view is not None:
            rows.append([*views, view])
            where.append(k)
    out = np.full(len(centres), np.nan)
    if not rows:
        return out
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


def _best(
    trial: SessionTrials, views: list[PoseView], target: F64, reach: Reach,
    options: EstimateOptions,
) -> tuple[F64, float, F64, float, int] | None:  # fmt: skip
    """The best reachable centre and its region, the thesis' move and its region.

    With them, how many candidates keep the target in view (None: none does).
    """
    taken = np.array([v.t_grid for v in views], dtype=np.float64)
    move = np.asarray(THESIS_MOVE_IN) * unit_factor(Units.IN, Units(trial.units))
    thesis_t = taken[-1] + move
    centres = np.vstack([lattice(taken[0], reach, taken), thesis_t])
    regions = predicted_regions(trial, views, target, centres, options)
    on_lattice = regions[:-1]
    if not np.isfinite(on_lattice).any():
        return None
    best = int(np.nanargmin(on_lattice))
    n = int(np.isfinite(on_lattice).sum())
    return centres[best], float(on_lattice[best]), thesis_t, float(regions[-1]), n


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
    centre, region, thesis_t, thesis_region, n = found
    return Suggestion(
        t_grid=_triple(centre),
        r_deg=_triple(views[-1].r_deg),
        predicted95=region,
        thesis_t_grid=_triple(thesis_t),
        thesis95=thesis_region,
        provisional=provisional,
        n_candidates=n,
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
        text = "no reachable pose keeps the target in view: choose the next pose yourself"
        return Advice(complete=False, region95=region95, text=text)
    more = None
    if target95 is not None:
        located = None if point is None else np.asarray(point, dtype=np.float64)
        more = _more_poses(trial, guidance, options, _target(trial, options, located),
                           suggestion)  # fmt: skip
    said = suggestion.text(units)
    if target95 is not None:
        said += (
            f"; {more} more pose(s) predicted to reach {target95:g} {units}"
            if more is not None
            else f"; {target95:g} {units} is not predicted within {guidance.max_poses} poses"
        )
    return Advice(
        complete=False, text=said, region95=region95, suggestion=suggestion, more_poses=more
    )


def _more_poses(
    trial: SessionTrials, guidance: Guidance, options: EstimateOptions, target: F64,
    first: Suggestion,
) -> int | None:  # fmt: skip
    """How many more poses the suggestions, one after the other, are predicted to need.

    To reach the target precision; None: not within ``max_poses``.
    """
    assert guidance.target95 is not None
    views = list(trial.views[0][:1] if first.provisional else trial.views[0])
    lines = spec_of(trial.method).uses_image_lines
    step, centre, region = 1, np.asarray(first.t_grid), first.predicted95
    while len(trial.views[0]) + step <= guidance.max_poses:
        if region <= guidance.target95:
            return step
        view = _predicted_view(views[-1], centre, target, lines=lines)
        found = None if view is None else _best(trial, [*views, view], target, guidance.reach,
                                                 options)  # fmt: skip
        if view is None or found is None:
            return None
        views.append(view)
        centre, region = found[0], found[1]
        step += 1
    return None


def _triple(v: F64) -> tuple[float, float, float]:
    return (float(v[0]), float(v[1]), float(v[2]))
