"""Guidance from the first pose (issues 46, 54): its regret against the true target's best
pose held to the same margin, per case and in poses to reach a target precision, and
whether the range it shows covers the region the second pose then gives.

    .venv/bin/python benchmarks/bench_first_pose.py [--cases 3] [--seed 0] [--write-docs]

One view cannot place the target along its ray. Targets at depths from 8 to 30 in along
rays like the thesis' (the sample scene's dot, or its finger, moved to that distance from
the first pose's camera, up to 1 in aside), each seen once from a first pose within 1 in of
the origin, measured as ``bench_guidance.py`` measures (5 frames, pixel noise, the
detector's floor, 1/16 in placing error, a 2 px calibration sigma). For each case:

- ``regret``: the suggested pose's region for the *true* target over the best region of
  any reachable lattice pose for it, both predicted alike
  (:func:`twopose.guidance.prediction.predicted_regions`) and both held to one margin: the one the
  pick keeps the target clear of the image's edges by (the depths weighed:
  :data:`twopose.guidance.first_pose.OTHER_DEPTHS_MARGIN`; a taped distance: the whole margin), less
  1: what guessing the depth cost. A pick that would put the true target within that
  margin (still in the image, but nearer its edge than the pick's margin allows; the true
  target stands up to 1 in off the first view's ray) has no region there: ``edge``. For
  the suggestion over the depths the scene allows (``range``, :mod:`twopose.guidance.first_pose`),
  for the one at a fixed 10 in (``10 in``, the assumption it replaces) and for the one at
  the taped true distance (``taped``);
- ``bound``: the least worst regret over the depths weighed that any lattice pose has for
  this case's first view, as the model predicts it (every pose predicted): what no single
  first pose could beat here without the distance;
- ``poses``: the poses the trial then needs to reach a 95% region within ``D`` (half the
  region the best second pose gives) when the second pose is the pick and every later one
  the recorder's suggestion, against the same from the best second pose (``best``): the
  regret in poses (a trial that does not reach ``D`` within :data:`MAX_POSES` counts as
  one more);
- ``covered``: the second pose taken where the suggestion says, the trial's 95% region
  (``semiaxis95``, as the live result shows it) lies within the range the first pose
  showed.

Targets (exit 1 if one is missed): no regret below zero (the pick and the best are held
to one margin), per method the worst regret of ``range`` at most 5% (issue 46's; the
``bound`` column says where no pose can reach it), and the range covers the second pose's
region in at least 95% of the cases.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from pathlib import Path

import numpy as np
from doc_figures import finished, run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bench_guidance import REACH, Truth, _trial, geometric_view  # type: ignore[import-not-found]  # noqa: E402

from twopose.guidance.advice import Suggestion, suggest  # noqa: E402
from twopose.guidance.first_pose import OTHER_DEPTHS_MARGIN, first_depths, provisional_target  # noqa: E402
from twopose.guidance.paper import lattice  # noqa: E402
from twopose.guidance.prediction import predicted_regions, regions95  # noqa: E402
from twopose.methods.specs import Method, spec_of  # noqa: E402
from twopose.methods.targets import finger_axis  # noqa: E402
from twopose.sim.scene import load_scene  # noqa: E402
from twopose.solve.estimate import EstimateOptions, PoseView  # noqa: E402
from twopose.solve.session import SessionTrials, estimate_session  # noqa: E402
from twopose.values.units import Units  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "first_pose.txt"
#: The true targets' distances from the first pose's camera (inches).
DEPTHS_IN = (8.0, 10.0, 12.0, 15.0, 20.0, 25.0, 30.0)
REGRET_TARGET = 0.05
COVER_TARGET = 0.95
#: A trial's most poses when counting the poses to reach D (the recorder's default).
MAX_POSES = 6
#: D, the target precision of the poses' count: this share of the best second pose's region.
D_SHARE = 0.5
K_SIGMA = np.array([2.0, 2.0, 2.0, 2.0])
K = np.array([525.0, 525.0, 320.0, 240.0])
PICKS = ("range", "10 in", "taped")


def _truth_at(method: Method, depth: float, first: np.ndarray, rng: np.random.Generator) -> Truth:
    """The scene's target moved to ``depth`` from ``first`` (its centroid), up to 1 in aside."""
    scene = load_scene()
    shift = rng.uniform(-1.0, 1.0, 2)
    k_true = K + K_SIGMA * rng.standard_normal(4)
    if not spec_of(method).uses_image_lines:
        ray = np.asarray(scene.point.position) + np.array([shift[0], shift[1], 0.0])
        p = first + depth * ray / np.linalg.norm(ray)
        return Truth(points=np.stack([p, p]), truth=np.stack([p, p]), ground=None, k_true=k_true)
    f, h = scene.finger, scene.ground_height
    gx, gz = f.ground_point[0] + shift[0] + first[0], f.ground_point[1] + first[2]
    for _ in range(8):  # move the finger along z until its centroid is ``depth`` away
        tip, base = finger_axis((gx, gz), h, f.tilt_deg, f.azimuth_deg, f.tip_height, f.length)
        mid = 0.5 * (tip + base) - first
        gz += math.sqrt(max(depth**2 - mid[0] ** 2 - mid[1] ** 2, 1.0)) - mid[2]
    tip, base = finger_axis((gx, gz), h, f.tilt_deg, f.azimuth_deg, f.tip_height, f.length)
    if method is Method.LINE:
        return Truth(points=np.stack([tip, base]), truth=np.stack([tip, base]), ground=None,
                     k_true=k_true)  # fmt: skip
    g = np.array([gx, h, gz])
    return Truth(points=np.stack([tip, base]), truth=np.stack([g, g]),
                 ground=(np.array([0.0, 1.0, 0.0]), h), k_true=k_true)  # fmt: skip


def _true_target(truth: Truth) -> np.ndarray:
    """(2, 3) the true target as guidance predicts views of it: the centroid, the line."""
    mid = truth.points.mean(axis=0)
    d = truth.points[1] - truth.points[0]
    if not np.linalg.norm(d):
        return np.stack([mid, mid])
    return np.stack([mid, mid + 0.2 * d / np.linalg.norm(d)])


@dataclasses.dataclass
class Case:
    method: str
    depth: float
    seed: int
    regret: dict[str, float]  # inf: the pick puts the true target within its margin
    bound: float  # this case's least worst regret over the depths weighed, any pose
    lo: float
    hi: float
    second: float  # the second pose's region (NaN: not in view or not solved)
    poses: float  # poses to reach D from the pick (MAX_POSES + 1: not within MAX_POSES)
    best_poses: float  # the same from the best second pose
    seconds: float  # the range suggestion's CPU time


def _bound(trial: SessionTrials, view: PoseView, options: EstimateOptions) -> float:
    """The least worst regret over the depths weighed of any lattice pose (all predicted)."""
    depths = first_depths(view, Units.IN, trial.ground, options)
    every = lattice(view.t_grid, REACH, view.t_grid[None])
    regions = np.stack([
        predicted_regions(trial, [view], provisional_target(view, Units.IN, trial.ground,
                                                            options, d),
                          every, options, margin=OTHER_DEPTHS_MARGIN)
        for d in depths
    ])  # fmt: skip
    best = np.nanmin(regions, axis=1)
    regret = np.max(regions / best[:, None], axis=0)  # NaN where a depth loses the target
    return float(np.nanmin(regret)) - 1 if np.isfinite(regret).any() else math.nan


def _poses_to(method: Method, truth: Truth, views: list[PoseView], second: np.ndarray,
              d95: float, noise: np.random.Generator) -> float:  # fmt: skip
    """Poses to a region within ``d95``: the second at ``second``, then the suggestions."""
    views = list(views)
    typed: np.ndarray | None = second
    while typed is not None and len(views) < MAX_POSES:
        view = geometric_view(method, truth, typed, len(views) + 1, noise)
        if view is None:
            break
        views.append(view)
        trial = _trial(method, truth, views)
        if float(regions95(trial, EstimateOptions())[0]) <= d95:
            return float(len(views))
        est = estimate_session(trial, EstimateOptions()).estimates
        point = est.point[0] if est.status[0] == "ok" else None
        found = suggest(trial, REACH, point=point)
        typed = None if found is None else np.asarray(found.t_grid)
    return float(MAX_POSES + 1)


def _case(method: Method, depth: float, seed: int) -> Case | None:
    rng = np.random.default_rng(seed)
    first = np.array([rng.integers(-2, 3) * 0.5, 0.0, rng.integers(-2, 3) * 0.5])
    truth = _truth_at(method, depth, first, rng)
    noise = np.random.default_rng(seed + 10_000)
    view = geometric_view(method, truth, first, 1, noise)
    if view is None:
        return None
    trial = _trial(method, truth, [view])
    options = EstimateOptions()
    started = time.process_time()
    picks: dict[str, Suggestion | None] = {"range": suggest(trial, REACH, options)}
    seconds = time.process_time() - started
    picks["10 in"] = suggest(trial, REACH, options, target_distance=10.0)
    picks["taped"] = suggest(trial, REACH, options, target_distance=depth)
    target = _true_target(truth)
    every = lattice(first, REACH, first[None])
    regret, best_at = {}, {}
    for name, s in picks.items():
        # One margin: the pick's own (the depths weighed: OTHER_DEPTHS_MARGIN; a single
        # taped or assumed depth: the whole), for the pick and for the best it is held to.
        margin = OTHER_DEPTHS_MARGIN if name == "range" else 1.0
        asked = every if s is None else np.vstack([every, np.asarray(s.t_grid)[None]])  # one batch
        regions = predicted_regions(trial, [view], target, asked, options, margin=margin)
        k = int(np.nanargmin(regions[: len(every)]))
        best_at[name] = every[k]
        own = math.nan if s is None else float(regions[-1])
        ratio = own / float(regions[k]) - 1 if math.isfinite(own) else math.inf
        regret[name] = 0.0 if -1e-9 < ratio < 0 else ratio  # a lattice pose typed as 1.2
    chosen = picks["range"]
    lo = hi = second = poses = best_poses = math.nan
    if chosen is not None and chosen.predicted95_range is not None:
        lo, hi = chosen.predicted95_range
        second_view = geometric_view(method, truth, np.asarray(chosen.t_grid), 2,
                                     np.random.default_rng(seed + 20_000))  # fmt: skip
        if second_view is not None:
            second = float(regions95(_trial(method, truth, [view, second_view]), options)[0])
        best_view = geometric_view(method, truth, best_at["range"], 2,
                                   np.random.default_rng(seed + 20_000))  # fmt: skip
        best_region = math.nan if best_view is None else float(
            regions95(_trial(method, truth, [view, best_view]), options)[0])  # fmt: skip
        d95 = D_SHARE * best_region
        poses = _poses_to(method, truth, [view], np.asarray(chosen.t_grid), d95,
                          np.random.default_rng(seed + 20_000))  # fmt: skip
        best_poses = _poses_to(method, truth, [view], best_at["range"], d95,
                               np.random.default_rng(seed + 20_000))  # fmt: skip
    return Case(method=str(method), depth=depth, seed=seed, regret=regret,
                bound=_bound(trial, view, options), lo=lo, hi=hi, second=second, poses=poses,
                best_poses=best_poses, seconds=seconds)  # fmt: skip


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", type=int, default=3, help="cases per method and depth")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    started = time.perf_counter()
    cases = [
        c
        for method in (Method.POINT, Method.LINE, Method.GROUND)
        for i, depth in enumerate(DEPTHS_IN)
        for k in range(args.cases)
        if (c := _case(method, depth, args.seed + 1000 * i + k)) is not None
    ]
    _per_case(cases)
    missed = _summary(cases, args)
    return finished(started, missed)


def _pct(value: float) -> str:
    return "edge" if math.isinf(value) else f"{value:.1%}"


def _per_case(cases: list[Case]) -> None:
    """Every case: its regrets, its bound, its poses to D against the best's."""
    print("each case: the regret of each pick for the true target (held to the pick's own "
          "margin, as its best is), this first view's bound (the least worst regret any pose "
          f"has over the depths weighed), and the poses to a region within D = {D_SHARE:g} x "
          "the best second pose's, the pick then the suggestions against the best then the "
          f"suggestions ({MAX_POSES + 1}: not within {MAX_POSES})\n")  # fmt: skip
    print(f"{'method':<7}{'in':>4}{'seed':>6}" + "".join(f"{n:>9}" for n in PICKS)
          + f"{'bound':>8}{'poses':>7}{'best':>6}{'more':>6}{'covered':>9}")  # fmt: skip
    for c in cases:
        covered = c.lo * (1 - 1e-9) <= c.second <= c.hi * (1 + 1e-9)
        more = c.poses - c.best_poses
        print(f"{c.method:<7}{c.depth:>4g}{c.seed:>6}"
              + "".join(f"{_pct(c.regret[n]):>9}" for n in PICKS)
              + f"{_pct(c.bound):>8}{c.poses:>7.0f}{c.best_poses:>6.0f}{more:>+6.0f}"
              f"{'yes' if covered else 'no':>9}")  # fmt: skip


def _summary(cases: list[Case], args: argparse.Namespace) -> list[str]:
    depths = ", ".join(f"{d:g}" for d in DEPTHS_IN)
    print(f"\n{args.cases} cases per method and true distance ({depths} in): regret mean and "
          "worst per pick (edge: the pick puts the true target within its margin), the "
          "largest bound, the range shown and the second pose's region (medians), covered, "
          "and the poses the pick costs beside the best second pose (mean)\n")  # fmt: skip
    print(f"{'method':<7}{'in':>4}" + "".join(f"{n + ' mean':>12}{'worst':>8}" for n in PICKS)
          + f"{'bound':>7}{'shown range':>14}{'second':>8}{'covered':>9}{'poses':>7}")  # fmt: skip
    missed = []
    for method in dict.fromkeys(c.method for c in cases):
        mine = [c for c in cases if c.method == method]
        for depth in (*DEPTHS_IN, math.nan):
            part = mine if math.isnan(depth) else [c for c in mine if c.depth == depth]
            if not part:
                continue
            cells = ""
            for n in PICKS:
                r = np.array([c.regret[n] for c in part])
                finite = r[np.isfinite(r)]
                mean = f"{np.mean(finite):.1%}" if finite.size else "edge"
                cells += f"{mean:>12}{_pct(float(np.max(r))):>8}"
            covered = [c.lo * (1 - 1e-9) <= c.second <= c.hi * (1 + 1e-9) for c in part]
            label = "all" if math.isnan(depth) else f"{depth:g}"
            shown = f"{np.median([c.lo for c in part]):.3g}-{np.median([c.hi for c in part]):.3g}"
            more = np.nanmean([c.poses - c.best_poses for c in part])
            print(f"{method:<7}{label:>4}{cells}{np.nanmax([c.bound for c in part]):>7.1%}"
                  f"{shown:>14}{np.nanmedian([c.second for c in part]):>8.3g}"
                  f"{np.mean(covered):>9.0%}{more:>+7.2f}")  # fmt: skip
            if math.isnan(depth):
                missed += _missed(method, part, covered)
    cost = np.array([c.seconds for c in cases])
    within = np.mean([c.bound <= 0.10 for c in cases])
    print(f"\nper case, a first pose within 10% of the best at every depth weighed exists in "
          f"{within:.0%} of the cases (the bound); the pick's regret is within 10% in "
          f"{np.mean([c.regret['range'] <= 0.10 for c in cases]):.0%}, and it costs no more "
          f"poses to D than the best second pose in "
          f"{np.mean([c.poses <= c.best_poses for c in cases]):.0%}")  # fmt: skip
    print(f"the first suggestion (over the depths): median {np.median(cost):.2f} s, largest "
          f"{cost.max():.2f} s of CPU time; the targets: no regret below zero, worst regret <= "
          f"{REGRET_TARGET:.0%} and covered >= {COVER_TARGET:.0%} per method")  # fmt: skip
    return missed


def _missed(method: str, part: list[Case], covered: list[bool]) -> list[str]:
    out = []
    regrets = [r for c in part for r in c.regret.values()]
    if min(regrets) < -1e-9:
        out.append(f"{method}: a regret below zero ({min(regrets):.1%})")
    worst = max(c.regret["range"] for c in part)
    if worst > REGRET_TARGET:
        # said with what no first pose could do here (issue 46's 5% is out of reach of any)
        bound = np.nanmax([c.bound for c in part])
        out.append(f"{method}: worst first-pose regret {_pct(worst)} (issue 46's "
                   f"{REGRET_TARGET:.0%}; no first pose reaches it in every case: the least "
                   f"worst regret any pose has is up to {bound:.1%} here)")  # fmt: skip
    if np.mean(covered) < COVER_TARGET:
        out.append(f"{method}: the range covers {np.mean(covered):.0%}")
    return out


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
