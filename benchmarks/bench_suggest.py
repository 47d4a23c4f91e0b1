"""What a suggestion costs, and how far its pick is from the whole lattice's best (issue 44).

    .venv/bin/python benchmarks/bench_suggest.py [--cases 160] [--regret-cases 60] [--seed 0]

Each case is a trial in the thesis' geometry (the sample scene's dot or finger, moved up to
1 in in x and z), in inches, centimetres or millimetres, with 1 to 6 accepted poses (the
first anywhere within 1 in of the origin, typed to 1/16 in and not on the paper's lines;
the others random poses on the paper that keep the target in view, within 3 in of the
first), 5 frames a pose with 0.3 px of centroid noise, a calibration 1-sigma of 2 px. Its
grid is drawn from 1 mm to 1 in and its reach from 1 in to 100 in (:data:`GRIDS_IN`,
:data:`REACHES_IN`; the reach at least the grid), the method from point, line and ground.

- **cost**: the wall time of :func:`twopose.guidance.advise` as the recorder calls it
  after an accepted pose, with a target precision no pose reaches (so the prediction of
  the poses still needed looks as far ahead as it may) and ``max_poses`` 10: what the
  operator waits from accept to the next prompt. Its 95th percentile over the cases, and
  per reach and per pose count.
- **map**: the CPU time of :func:`twopose.region_map.region_map` after that advice: what
  the terminal (which waits for it) and the console (which draws it when ready) add to it;
  a plan computes no map.
- **regret** (cases of two poses or more: a first pose's pick weighs every depth along its
  ray, and ``bench_first_pose.py`` measures it): the suggestion's predicted region over the
  best region of every lattice pose
  in reach that keeps the target clear of the image's edges (each predicted by the same
  batch estimate), less one. A lattice of more than :data:`FULL_LIMIT` such poses is not
  predicted whole: its reference is the best of a sub-lattice of about that many poses and
  of every pose within :data:`WINDOW` lines of that best and of the pick (``sampled``).

Targets (exit 1 if one is missed): the cost's 95th percentile at most 1 s, every regret at
most 2%.
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from twopose.estimate import EstimateOptions, PoseView  # noqa: E402
from twopose.guidance import (  # noqa: E402
    Guidance,
    Reach,
    _template,
    advise,
    predicted_regions,
    suggest,
    target_of,
)
from twopose.methods import Method, spec_of  # noqa: E402
from twopose.paper_search import clear_of_edges, field_in_view, half_planes  # noqa: E402
from twopose.region_map import MAP_POSES, region_map  # noqa: E402
from twopose.session_estimate import SessionTrials, estimate_session  # noqa: E402
from twopose.sim.scene import load_scene  # noqa: E402
from twopose.solve import projection_matrices  # noqa: E402
from twopose.targets import finger_axis  # noqa: E402
from twopose.units import Units, unit_factor  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "suggest.txt"

K = np.array([525.0, 525.0, 320.0, 240.0])
FRAMES, PIXEL_SIGMA, THETA_SIGMA = 5, 0.3, 0.5
MM = 1 / 25.4
#: Grid paper from 1 mm to 1 in, and reaches from 1 in to the bound's 100 in (inches).
GRIDS_IN = (MM, 2 * MM, 1 / 16, 5 * MM, 0.25, 10 * MM, 0.5, 1.0)
REACHES_IN = (1.0, 3.0, 10.0, 30.0, 100.0)
#: A lattice of more poses in view than this is not predicted whole (its reference sampled).
FULL_LIMIT = 4000
WINDOW = 6
COST_TARGET_S, REGRET_TARGET = 1.0, 0.02


@dataclass(frozen=True, kw_only=True)
class Case:
    method: Method
    units: Units
    grid_in: float
    reach_in: float
    poses: int
    seed: int


def _points(method: Method, rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, float]:
    """The target's two points as the camera sees them (inches), the truth, ground height."""
    scene = load_scene()
    shift = rng.uniform(-1.0, 1.0, 2)
    if not spec_of(method).uses_image_lines:
        p = np.asarray(scene.point.position) + np.array([shift[0], 0.0, shift[1]])
        return np.stack([p, p]), np.stack([p, p]), scene.ground_height
    f = scene.finger
    gx, gz = f.ground_point[0] + shift[0], f.ground_point[1] + shift[1]
    tip, base = finger_axis((gx, gz), scene.ground_height, f.tilt_deg, f.azimuth_deg,
                            f.tip_height, f.length)  # fmt: skip
    truth = np.stack([tip, base])
    if method is Method.GROUND:
        g = np.array([gx, scene.ground_height, gz])
        truth = np.stack([g, g])
    return np.stack([tip, base]), truth, scene.ground_height


def _view(points: np.ndarray, t: np.ndarray, pose: int, lines: bool, factor: float,  # noqa: FBT001 - a private helper
          rng: np.random.Generator) -> PoseView:  # fmt: skip
    P = projection_matrices(K, np.eye(3), t)
    h = np.column_stack([points, np.ones(2)]) @ P.T
    px = h[:, :2] / h[:, 2:3]
    centroid = px.mean(axis=0) if lines else px[0]
    d = px[1] - px[0]
    theta = math.degrees(math.atan2(d[1], d[0])) if lines else math.nan
    return PoseView(
        pose=pose, intrinsics=K, width_height=(640, 480), t_grid=t, r_deg=np.zeros(3),
        t_sigma=0.0625 * factor / 2, r_sigma_deg=0.0,
        centroids=centroid + PIXEL_SIGMA * rng.standard_normal((FRAMES, 2)),
        thetas=theta + THETA_SIGMA * rng.standard_normal(FRAMES),
        found=np.ones(FRAMES, dtype=bool), camera_id="cam0", intrinsics_sigma=np.full(4, 2.0),
    )  # fmt: skip


def _trial(case: Case) -> tuple[SessionTrials, np.ndarray | None, Reach]:
    """The case's trial in session units, its estimate (None: one pose) and its reach."""
    rng = np.random.default_rng(case.seed)
    f = unit_factor(Units.IN, case.units)
    points, truth, ground_h = _points(case.method, rng)
    points, truth = points * f, truth * f
    lines = spec_of(case.method).uses_image_lines
    first = np.round(rng.uniform(-1.0, 1.0, 3) * 16) / 16 * f
    first[1] = 0.0
    spacing = case.grid_in * f
    views = [_view(points, first, 1, lines, f, rng)]
    target = np.stack([points.mean(axis=0), points[1]]) if lines else points
    for _ in range(200):  # random poses on the paper, in view, within 3 in of the first
        if len(views) == case.poses:
            break
        t = first + np.array([rng.uniform(-3, 3), 0.0, rng.uniform(-3, 3)]) * f
        t[[0, 2]] = np.round(t[[0, 2]] / spacing) * spacing
        if clear_of_edges(views[0], t[None], target, case.units, lines=lines)[0]:
            views.append(_view(points, t, len(views) + 1, lines, f, rng))
    ground = (np.array([0.0, 1.0, 0.0]), ground_h * f) if case.method is Method.GROUND else None
    trial = SessionTrials(method=case.method, units=str(case.units), trial_ids=(1,),
                          views=[views], truth=truth[None], ground=ground)  # fmt: skip
    point = None
    if len(views) >= 2:
        est = estimate_session(trial, EstimateOptions()).estimates
        point = est.point[0] if est.status[0] == "ok" else None
    reach = Reach(radius=max(case.reach_in, case.grid_in) * f, spacing=spacing)
    return trial, point, reach


def _cases(n: int, seed: int) -> list[Case]:
    rng = np.random.default_rng(seed)
    out = []
    for k in range(n):
        grid = GRIDS_IN[rng.integers(len(GRIDS_IN))]
        reach = REACHES_IN[rng.integers(len(REACHES_IN))]
        out.append(Case(
            method=(Method.POINT, Method.LINE, Method.GROUND)[k % 3],
            units=(Units.IN, Units.CM, Units.MM)[rng.integers(3)],
            grid_in=grid, reach_in=max(reach, grid), poses=1 + (k // 3) % 6,
            seed=seed + k,
        ))  # fmt: skip
    return out


def _cost(case: Case) -> tuple[float, float, float]:
    """The wall and the CPU time of the advice after the case's last pose, and the CPU
    time of the map the console and the terminal add to it (:mod:`twopose.region_map`)."""
    trial, point, reach = _trial(case)
    guidance = Guidance(reach=reach, target95=1e-6, max_poses=10)
    wall, cpu = time.perf_counter(), time.process_time()
    advice = advise(trial, guidance, point=None if point is None else point.tolist())
    spent = time.perf_counter() - wall, time.process_time() - cpu
    cpu = time.process_time()
    region_map(trial, reach, point=point, suggestion=advice.suggestion)
    return spent[0], spent[1], time.process_time() - cpu


def _reference(case: Case) -> tuple[float, float, int, bool]:
    """The pick's region, the reference best, the poses predicted for it, whether sampled."""
    trial, point, reach = _trial(case)
    options = EstimateOptions()
    views = trial.views[0]
    found = suggest(trial, reach, options, point=None if point is None else point.tolist())
    if found is None:
        return math.nan, math.nan, 0, False
    located = None if point is None else np.asarray(point)
    target = target_of(trial, options, located)
    lines = spec_of(trial.method).uses_image_lines
    taken = np.array([v.t_grid for v in views])
    planes = half_planes(_template(views), target, Units(trial.units), float(taken[0][1]),
                          lines=lines)  # fmt: skip
    field = field_in_view(taken[0], reach, planes)
    total = field.count()
    step = 1 if total <= FULL_LIMIT else math.ceil(math.sqrt(total / FULL_LIMIT))
    ij = _lattice_points(field, step)
    best, n = _best_of(trial, views, target, field, ij, taken, options)
    sampled = step > 1
    if sampled:  # every pose near the sample's best and near the pick
        s = reach.spacing
        pick = (round(found.t_grid[0] / s), round(found.t_grid[2] / s))
        near = [p for c in (best[1], pick) for p in _window(field, c)]
        local, m = _best_of(trial, views, target, field, np.array(near), taken, options)
        best, n = min(best, local), n + m
    return found.predicted95, best[0], n, sampled


def _lattice_points(field: object, step: int) -> np.ndarray:
    out = []
    for j, lo, hi in zip(field.rows, field.lo, field.hi, strict=True):  # type: ignore[attr-defined]
        if lo <= hi and j % step == 0:
            first = -(-int(lo) // step) * step
            out += [(i, int(j)) for i in range(first, int(hi) + 1, step)]
    return np.array(out, dtype=np.int64).reshape(-1, 2)


def _window(field: object, at: tuple[int, int]) -> list[tuple[int, int]]:
    out = []
    for j in range(at[1] - WINDOW, at[1] + WINDOW + 1):
        lo, hi = field.interval(j)  # type: ignore[attr-defined]
        out += [(i, j) for i in range(max(lo, at[0] - WINDOW), min(hi, at[0] + WINDOW) + 1)]
    return out


def _best_of(trial: SessionTrials, views: list[PoseView], target: np.ndarray, field: object,
             ij: np.ndarray, taken: np.ndarray,
             options: EstimateOptions) -> tuple[tuple[float, tuple[int, int]], int]:  # fmt: skip
    if not len(ij):
        return (math.inf, (0, 0)), 0
    centres = field.centres(ij)  # type: ignore[attr-defined]
    gaps = np.linalg.norm(centres[:, None, :] - taken[None, :, :], axis=-1)
    free = (gaps > field.spacing / 2).all(axis=1)  # type: ignore[attr-defined]
    ij, centres = ij[free], centres[free]
    regions = np.concatenate([
        predicted_regions(trial, views, target, centres[k : k + 500], options)
        for k in range(0, len(centres), 500)
    ]) if len(centres) else np.zeros(0)  # fmt: skip
    regions = np.where(np.isnan(regions), np.inf, regions)
    if not len(regions) or not np.isfinite(regions).any():
        return (math.inf, (0, 0)), len(regions)
    k = int(np.argmin(regions))
    return (float(regions[k]), (int(ij[k][0]), int(ij[k][1]))), len(regions)


def _describe(case: Case) -> str:
    f = unit_factor(Units.IN, case.units)
    return (f"{case.method!s:<7}{case.units!s:>4}{case.grid_in * f:>8.3g}{case.reach_in * f:>8.4g}"
            f"{case.poses:>6}")  # fmt: skip


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", type=int, default=180)
    parser.add_argument("--regret-cases", type=int, default=60)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    started = time.perf_counter()
    cases = _cases(args.cases, args.seed)
    load = os.getloadavg()[0]
    both = np.array([_cost(c) for c in cases])
    walls, costs, maps = both[:, 0], both[:, 1], both[:, 2]
    p95 = float(np.percentile(costs, 95))
    print(f"{len(cases)} cases: grids 1 mm to 1 in, reaches 1 to 100 in (or their cm, mm), "
          "units in/cm/mm, 1-6 poses, point/line/ground; the time of advise() from accept to "
          "the next prompt (the suggestion and the poses still needed)\n")  # fmt: skip
    print(
        f"cost (CPU time): median {np.median(costs):.2f} s, 95th percentile {p95:.2f} s, "
        f"largest {costs.max():.2f} s (target: 95th percentile <= {COST_TARGET_S:g} s)"
    )
    print(
        f"wall time: median {np.median(walls):.2f} s, 95th percentile "
        f"{np.percentile(walls, 95):.2f} s (load average {load:.1f} on {os.cpu_count()} "
        "cores when it started: the wall time is the CPU time on an idle machine)"
    )
    print(
        f"the map of every reachable pose (at most {MAP_POSES} predicted in one batch), the CPU "
        f"it adds per accepted pose (the terminal waits for it, the console draws it when "
        f"ready): median {np.median(maps):.2f} s, 95th percentile {np.percentile(maps, 95):.2f} s, "
        f"largest {maps.max():.2f} s; the advice with it: 95th percentile "
        f"{np.percentile(costs + maps, 95):.2f} s"
    )
    print(f"\n{'reach in':>9}{'cases':>7}{'p95 s':>8}      {'poses':>6}{'cases':>7}{'p95 s':>8}")
    reaches = sorted({c.reach_in for c in cases})
    poses = sorted({c.poses for c in cases})
    for k in range(max(len(reaches), len(poses))):
        left = right = ""
        if k < len(reaches):
            sel = np.array([c.reach_in == reaches[k] for c in cases])
            left = f"{reaches[k]:>9.4g}{sel.sum():>7}{np.percentile(costs[sel], 95):>8.2f}"
        if k < len(poses):
            sel = np.array([c.poses == poses[k] for c in cases])
            right = f"{poses[k]:>6}{sel.sum():>7}{np.percentile(costs[sel], 95):>8.2f}"
        print(f"{left:<24}      {right}")
    worst = np.argsort(costs)[::-1][:3]
    print("\nslowest (method, units, grid, reach, poses):")
    for k in worst:
        print(f"  {_describe(cases[k])}  {costs[k]:.2f} s")
    print(
        f"\nregret: the pick's region / the lattice's best - 1, {args.regret_cases} cases "
        f"(a lattice of more than {FULL_LIMIT} poses in view: sampled, see the docstring)"
    )
    print(f"{'method':<7}{'units':>4}{'grid':>8}{'reach':>8}{'poses':>6}{'predicted':>10}"
          f"{'pick':>9}{'best':>9}{'regret':>8}")  # fmt: skip
    regrets = []
    # A pick from one pose weighs every depth along the ray (twopose/first_pose.py): it is
    # no search for one target's best, so its regret is bench_first_pose.py's measure.
    for case in [c for c in cases if c.poses >= 2][: args.regret_cases]:
        pick, best, n, sampled = _reference(case)
        if not math.isfinite(best):
            print(f"{_describe(case)}  no pose keeps the target in view")
            continue
        regret = pick / best - 1
        regrets.append(regret)
        print(f"{_describe(case)}{n:>10}{'s' if sampled else ' '}{pick:>8.4g}{best:>9.4g}"
              f"{regret:>8.2%}")  # fmt: skip
    r = np.array(regrets)
    print(f"\nregret over {len(r)} cases: median {np.median(r):.2%}, 95th percentile "
          f"{np.percentile(r, 95):.2%}, largest {r.max():.2%} (target: every one <= "
          f"{REGRET_TARGET:.0%})")  # fmt: skip
    print(f"({time.perf_counter() - started:.0f} s)")
    missed = []
    if p95 > COST_TARGET_S:
        missed.append(f"the cost's 95th percentile is {p95:.2f} s")
    if r.max() > REGRET_TARGET:
        missed.append(f"a regret of {r.max():.2%}")
    for line in missed:
        print(f"target missed: {line}")
    return 1 if missed else 0


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
