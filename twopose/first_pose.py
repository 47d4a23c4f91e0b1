"""Guidance from the first pose: the depths one view leaves open, and the pose for all of them.

One view cannot place the target along its ray (one ray, or one plane). The target may lie
at any depth the scene allows, from :data:`NEAR_DEPTH_IN` (nearer, a hand would not stay in
focus, and the finger's length would not stay clear of a webcam's image's edges) to
:data:`FAR_DEPTH_IN` (beyond arm's length across a table) or, for method 2, to where the
ray meets the ground if that is nearer (the finger stands above the ground it points at).
Unless the operator has taped the distance (``Guidance.target_distance``), the first
suggestion is the pose whose worst regret over :data:`DEPTHS` depths across that range is
least: at each depth, its predicted region over the best pose's for a target there
(:func:`minimax_pick`). Its predicted region is then a range, the least and the most over
those depths. ``benchmarks/bench_first_pose.py`` measures its regret against the true
target's best pose and whether the range covers the region the second pose then gives.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from twopose.arrays import F64
from twopose.camera import grid_rays, rotation_from_angles_deg
from twopose.estimate import EstimateOptions, GroundSpec, PoseView, measure
from twopose.paper_search import COARSE_CANDIDATES, SEEDS, Field, Found, search
from twopose.units import Units, unit_factor

__all__ = [
    "DEPTHS",
    "FAR_DEPTH_IN",
    "NEAR_DEPTH_IN",
    "OTHER_DEPTHS_MARGIN",
    "RANGE_SLACK",
    "REGRET_COARSE",
    "FirstPick",
    "assumed_depth",
    "depth_range",
    "first_depths",
    "first_ray",
    "minimax_pick",
    "provisional_target",
]

#: The nearest a target is assumed along the first view's ray (inches): a webcam's fixed
#: focus blurs a hand nearer, and the finger's length (3 in) then spans most of the image.
NEAR_DEPTH_IN = 8.0
#: The farthest (inches): beyond arm's length across a table, and beyond the thesis' scene
#: (targets at 9-13 in) by more than twice.
FAR_DEPTH_IN = 30.0
#: The depths weighed between the two, spaced geometrically (the region grows about as the
#: square of the depth, so equal ratios weigh the near and far ends alike).
DEPTHS = 5
#: The pick keeps the target in view at every depth weighed by this share of the margins
#: a located target is kept clear by (:data:`twopose.paper_search.IN_VIEW_MARGIN`,
#: :data:`~twopose.paper_search.END_MARGIN`): the pose a far target needs often puts a
#: near one close to the image's edge, and half the margins ruled it out (a worst regret of
#: 38% at 25 in for the dot); with none, a placing error took a target at 8 in out of the
#: second view (``bench_first_pose.py`` chose it).
OTHER_DEPTHS_MARGIN = 0.1
#: The search over the worst regret starts from a coarse pass of about this many poses: a
#: worst over depths has kinks the pattern search stalls on (with 40 and no margin, a dot at
#: 25 in got a pick 38% worse than its best, with 80 11%, as predicting the whole thesis'
#: lattice); a wide reach costs about the same, its depths' own searches dominate.
REGRET_COARSE = 2 * COARSE_CANDIDATES
#: The range shown is widened by this share each way: the second pose's own frames and
#: placing error move its region by a few percent about the prediction, and for the finger
#: the provisional line's direction (steepest down in the view's plane) is a guess (the
#: taped distance's pick is up to 13% off for method 2): 10% left the second pose's region
#: of a ground target at 30 in outside the range in 2 of 3 cases (``bench_first_pose.py``).
RANGE_SLACK = 0.15


def first_ray(view: PoseView, options: EstimateOptions) -> tuple[F64, F64, F64]:
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


def first_depths(
    view: PoseView, units: Units, ground: GroundSpec | None, options: EstimateOptions,
    taped: float | None = None,
) -> F64:  # fmt: skip
    """(D,) the depths along the first view's ray a target seen once may lie at.

    :func:`twopose.first_pose.depth_range`: the taped distance, or the scene's range.
    """
    centre, ray, _ = first_ray(view, options)
    return depth_range(centre, ray, units, ground, taped)


def assumed_depth(depths: F64) -> float:
    """The depth the suggestion's single figures assume: the middle of ``depths``."""
    return float(depths[len(depths) // 2])


def provisional_target(
    view: PoseView, units: Units, ground: GroundSpec | None, options: EstimateOptions,
    depth: float | None = None,
) -> F64:  # fmt: skip
    """(2, 3) a target one pose cannot locate, assumed ``depth`` along the first view's ray.

    ``depth`` (session units): None, the middle of the scene's range (:func:`first_depths`,
    :func:`assumed_depth`). The point twice, or two points of the finger's line (the first
    its centroid).
    """
    centre, ray, normal = first_ray(view, options)
    if depth is None:
        depth = assumed_depth(depth_range(centre, ray, units, ground))
    point = centre + depth * ray
    if not np.isfinite(normal).all():
        return np.stack([point, point])
    down = np.array([0.0, 1.0, 0.0])  # y is down: the finger points at the ground
    direction = down - np.dot(down, normal) * normal
    direction /= np.linalg.norm(direction)
    return np.stack([point, point + depth * 0.02 * direction])


def depth_range(
    centre: F64, ray: F64, units: Units, ground: GroundSpec | None,
    taped: float | None = None,
) -> F64:  # fmt: skip
    """(D,) the depths (session units) along the unit ``ray`` from ``centre`` to weigh.

    ``taped``: the operator's taped distance from the first pose's camera to the target,
    the one depth. Else :data:`DEPTHS` depths from :data:`NEAR_DEPTH_IN` to
    :data:`FAR_DEPTH_IN`, or to where the ray meets the ground if nearer.
    """
    if taped is not None:
        return np.array([float(taped)])
    factor = unit_factor(Units.IN, units)
    near, far = NEAR_DEPTH_IN * factor, FAR_DEPTH_IN * factor
    if ground is not None:
        n, offset = ground
        along = float(np.dot(n, ray))
        if along > 1e-9:
            far = min(far, (offset - float(np.dot(n, centre))) / along)
    if far <= near:  # the ground is near: the range shrinks to it
        return np.array([max(far, 1e-6 * factor)])
    return np.geomspace(near, far, DEPTHS)


#: A prediction at some depths: (M, 3) camera centres and the depths' indices (R,) to
#: their (R, M) regions (NaN: out of view, unsolved).
PredictDepths = Callable[[F64, list[int]], F64]


@dataclass(frozen=True, kw_only=True)
class FirstPick:
    """The first suggestion's pose and what each depth predicts for it."""

    found: Found  # the pick (its ``region``: the largest regret, a ratio >= 1)
    regions: F64  # (D,) its predicted region at each depth
    best: F64  # (D,) the best pose's region at each depth (NaN: no pose solves there)
    extra_regions: F64  # (D, E) the ``extra`` poses' regions at each depth
    n_predicted: int  # poses whose region was predicted at some depth (the search's cost)


class _Cache:
    """Each pose's region at each depth, predicted once (the searches share poses)."""

    def __init__(self, predict: PredictDepths, n_depths: int) -> None:
        self.predict, self.n = predict, n_depths
        self.known: dict[tuple[bytes, int], float] = {}

    def at(self, depth: int) -> Callable[[F64], F64]:
        """The prediction at one depth, as :func:`twopose.paper_search.search` takes it."""
        return lambda centres: self.regions(centres, [depth])[0]

    def regions(self, centres: F64, depths: list[int]) -> F64:
        """(len(depths), M) the regions of ``centres`` at ``depths``, predicting the new."""
        keys = [np.asarray(c, dtype=np.float64).tobytes() for c in centres]
        for d in depths:
            new = [m for m, k in enumerate(keys) if (k, d) not in self.known]
            if new:
                got = self.predict(centres[new], [d])[0]
                self.known.update(((keys[m], d), float(r)) for m, r in zip(new, got, strict=True))
        return np.array([[self.known[(k, d)] for k in keys] for d in depths]).reshape(
            len(depths), len(keys)
        )


def minimax_pick(
    predict: PredictDepths, fields: list[Field], field: Field, taken: F64, *, extra: F64,
    coarse: int = COARSE_CANDIDATES, seeds: int = SEEDS,
) -> FirstPick | None:  # fmt: skip
    """The pose of ``field`` whose worst regret over the depths is least (None: none solves).

    ``fields``: each depth's poses that keep a target there clear of the image's edges;
    ``field``: those that keep it clear at every depth (where the pick may go). The best
    region at each depth over its own field first (one search each), then the search over
    the regret ``max_d region_d / best_d`` over the depths some pose solves; a pose one of
    them cannot solve is left out.
    """
    n_depths = len(fields)
    cache = _Cache(predict, n_depths)
    best = np.full(n_depths, np.nan)
    for d, own in enumerate(fields):
        found = search(cache.at(d), own, taken, coarse=coarse, seeds=seeds)
        best[d] = math.nan if found is None else found.region
    weighed = [d for d in range(n_depths) if math.isfinite(best[d])]
    if not weighed:
        return None

    def regret(centres: F64) -> F64:
        ratio = cache.regions(centres, weighed) / best[weighed][:, None]
        return np.asarray(np.where(np.isnan(ratio).any(axis=0), np.nan, ratio.max(axis=0)))

    found = search(regret, field, taken, coarse=max(coarse, REGRET_COARSE), seeds=seeds)
    if found is None:
        return None
    every = list(range(n_depths))
    extra = np.asarray(extra, dtype=np.float64).reshape(-1, 3)
    return FirstPick(
        found=found, regions=cache.regions(found.centre[None], every)[:, 0], best=best,
        extra_regions=cache.regions(extra, every),
        n_predicted=len({key for key, _ in cache.known}),
    )  # fmt: skip
