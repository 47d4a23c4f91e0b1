"""Honest regions for any session size (issue 54): the placing variance's multiplier
always estimated and shrunk toward the operator's other sessions, robust per-trial tests
before pooling, and a blunder caught at its trial.

    .venv/bin/python benchmarks/bench_noise.py [--operators 4] [--sessions 20] [--seed 0]
        [--write-docs]

Sessions as a lab records them, in the simulator's geometry (``recorder.simulate.one_camera``'s
default scene and its pose draws, :func:`recorder.simulate.one_camera.draw_trial_poses`: free poses,
3 a trial, the target well inside every view; the point's dot, the finger for the line and
method 2), projected instead of rendered (a rendered session takes half a minute; the
rendered ones agree: ``tests/analysis/test_blunder_session.py``): 5 frames a pose with
0.3 px of centroid noise (0.5 deg on the orientation) and the detector's error at its
floor. The operator types 1/16 in (``poses.typed_resolution``) and places the laptop with
that error (typed right), 1.6x or 3x it. Per method, session size (2 to 5 trials) and
placing error, ``--operators`` operators of ``--sessions`` sessions each (issue 54: one
operator over 20+ sessions), each operator's sessions a run of their own, with the run's two
passes as ``twopose-analyze run`` does them (:mod:`analysis.batch.noise_pass`: each
session's misclosures, every session's prior from the operator's other sessions,
:func:`twopose.uncertainty.operator_pool.operator_priors`, then each session estimated with it).

Coverage: the share of ok trials whose truth lies in their 95% region ("pooled": the
run's rule; "alone": each session with the typed resolution's weak prior only; "typed":
the regions of the typed sigma, what today's rule gives when its test does not reject;
"given": the placing multiplier given exactly, the truth's, so that what "pooled" misses
beyond it is the multiplier's estimate and what "given" misses is the regions' own),
NEES/dof, and the regions' largest semi-axis over the typed sigma's (median). A cell's
coverage rests on its operators' multipliers (the trials of one operator share its estimate,
those of one session its misclosures): its 95% interval is a two-stage cluster bootstrap,
operators drawn with replacement, then each drawn operator's sessions.

The multiplier itself: pooled over ``--multiplier-sessions`` sessions of 5 trials as
:func:`operator_priors` pools an operator's (flagged trials out), over its truth (1,
2.56, 9): a bias of the estimate (the misclosures' nonlinearity) would show here, where one
operator's 20 sessions leave a 1-sigma of 8-23%.

Blunders: typed right, and in 20% of the trials one pose's typed x off by 1 in (either
sign): the share of blundered trials flagged (``by truth``: of them, those only the test
against their own recorded truth flagged, :mod:`twopose.uncertainty.blunders`), of clean
trials flagged, the clean trials' regions over the same sessions' typed right and over the
same sessions' with the blundered trials absent (what the blunder itself costs them beyond
its trial's information: a missed blunder in the pool; median with its 95% interval,
operators resampled, and 90th percentile), the coverage of the trials not flagged and of all of them
(``all cover``: the flagged ones in their own regions, widened by their misfit where a
misclosure or the other trials flagged them, not where the truth did: removing the trials
the truth flags is the one way the unflagged coverage can rise by it). The sessions'
trials measured one target (the scene's), so a trial is also tested against the others
(:mod:`twopose.uncertainty.blunders`); the same again with each trial its own target
(its truth 1e-6 in apart), where only its misclosure and its truth can see a blunder: the
share of blunders its poses can check at all (``seen``: a noncentrality Baarda's test
catches 80% of the time) and the flag rate among those.
With three poses and with four: how often the pose is named, and named right.

A cell is 8 operators of 20 sessions by default (4 until r8: a cell's coverage over the
sizes then scattered over seeds about as widely as the band, line at 3x 93.7-97.2% over
seven seeds; a run: about 40 min on one core); so is the first blunder table (per size),
the other two keep one operator's 160 sessions (``--operators`` x ``--sessions``).

Targets (exit 1 if one is missed): per method and placing error, over the sizes, pooled
coverage 93-97%, and per size no cell whose whole interval lies outside 93-97%; typed
right, the median region at most 1.10x the typed sigma's over the sizes, and per size no
cell whose whole interval (operators resampled) lies above 1.10x (a new user's r7 H1: the
2-trial ground cell read 1.13 unchecked; at 20 seeds it read 0.95-1.13, above 1.10 in 3,
its operators' mean multiplier 1.019: chance, judged as a cell's coverage is); with
blunders, per method,
>= 85% of blundered trials flagged, <= 2% of clean ones, the clean trials' median region
over the one with the blundered trials absent not above 1.02x (missed where its whole 95%
interval is) and its 90th percentile at most 1.10x, and the unflagged trials' coverage
93-97%.
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from collections.abc import Callable, Sequence
from pathlib import Path

import numpy as np
import pandas as pd
from doc_figures import finished, run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]
from scipy import optimize, special

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from recorder.simulate.one_camera import draw_trial_poses, target_points  # noqa: E402
from twopose.camera.model import project_points, rotation_from_angles_deg  # noqa: E402
from twopose.methods.planes import GROUND_PLANE  # noqa: E402
from twopose.methods.specs import Method, spec_of  # noqa: E402
from twopose.methods.truth import reported  # noqa: E402
from twopose.sim.layout import finger_axis  # noqa: E402
from twopose.sim.scene import Scene  # noqa: E402
from twopose.solve.estimate import EstimateOptions, PoseView  # noqa: E402
from twopose.solve.session import SessionEstimate, SessionTrials, estimate_session  # noqa: E402
from twopose.uncertainty.noise import NoiseModel, PlacingPrior, VarianceFactor  # noqa: E402
from twopose.uncertainty.operator_pool import operator_priors  # noqa: E402
from twopose.uncertainty.placing_variance import posterior  # noqa: E402
from twopose.uncertainty.propagate import uncertainty_columns  # noqa: E402
from twopose.uncertainty.robust_flags import BAARDA_LEVEL, flag_trials  # noqa: E402
from twopose.uncertainty.session_noise import operator_group, session_statistics  # noqa: E402
from twopose.values.units import Units  # noqa: E402

#: Each trial's poses, (typed t, typed r, true t, true r) each, as the simulator draws them.
Draw = Callable[[Scene, Method, int, np.random.Generator], Sequence[tuple[np.ndarray, ...]]]
#: The docs include this file (``--write-docs`` writes it).
FIGURE = "noise.txt"
TYPED_IN = 0.0625
#: The real placing error over the typed.
PLACINGS = (1.0, 1.6, 3.0)
SIZES = (2, 3, 4, 5)
METHODS = (Method.POINT, Method.LINE, Method.GROUND)
FRAMES, PIXEL_SIGMA, THETA_SIGMA = 5, 0.3, 0.5
BLUNDER_IN, BLUNDER_SHARE = 1.0, 0.2
COVERAGE_TARGET = (0.93, 0.97)
TYPED_WIDER, FLAGGED_LEAST, FALSE_MOST = 1.10, 0.85, 0.02
CLEAN_MEDIAN, CLEAN_P90 = 1.02, 1.10
#: The trials of each session whose pooled multiplier is checked against its truth.
MULTIPLIER_SIZE = 5
#: A cell's operators, each with ``--sessions`` sessions of their own (issue 54: one
#: operator over 20+ sessions), and the cluster bootstrap's draws for its interval.
OPERATORS, BOOT_DRAWS = 8, 2000
PLAIN = EstimateOptions(noise=NoiseModel(test_redundancy=False))


def session(method: Method, seed: int, trials: int, placing: float, poses: int = 3,
            scene: Scene | None = None,
            draw: Draw = draw_trial_poses) -> SessionTrials:  # fmt: skip
    """One session in the simulator's geometry, projected: ``placing`` x the typed error.

    ``draw``: each trial's poses (typed and true), the simulator's by default
    (``benchmarks/bench_misclosure_models.py`` draws the typed values otherwise)."""
    base = scene or Scene()
    p = dataclasses.replace(base.poses, count=poses, noise_sigma=placing * TYPED_IN,
                            typed_resolution=TYPED_IN)  # fmt: skip
    scene = dataclasses.replace(base, poses=p)
    rng = np.random.default_rng(seed)
    spec = spec_of(method)
    _, truth = target_points(scene, method)
    seen = np.stack(finger_axis(scene, spec.plane)) if spec.uses_image_lines else truth
    cam = scene.cameras[0]
    K = cam.intrinsics
    views = []
    for _ in range(trials):
        row = []
        for k, (typed, r_typed, t_true, r_true) in enumerate(draw(scene, method, poses, rng)):
            px = project_points(seen, K, rotation_from_angles_deg(r_true), t_true)
            centroid, theta = (
                (px.mean(axis=0), _angle(px)) if spec.uses_image_lines else (px[0], math.nan)
            )
            floor_px, floor_deg = spec.detector_floor
            centroid = centroid + floor_px * rng.standard_normal(2)
            theta += floor_deg * rng.standard_normal()
            row.append(PoseView(
                pose=k + 1, intrinsics=np.array([K.fx, K.fy, K.cx, K.cy]),
                width_height=(K.width, K.height), t_grid=np.asarray(typed, dtype=float),
                r_deg=np.asarray(r_typed, dtype=float), t_sigma=TYPED_IN, r_sigma_deg=1e-9,
                centroids=centroid + PIXEL_SIGMA * rng.standard_normal((FRAMES, 2)),
                thetas=theta + THETA_SIGMA * rng.standard_normal(FRAMES),
                found=np.ones(FRAMES, dtype=bool), camera_id=cam.id,
                intrinsics_sigma=np.zeros(4),
            ))  # fmt: skip
        views.append(row)
    point = truth if len(truth) == 2 else np.stack([truth[0], truth[0]])
    plane = spec.plane or GROUND_PLANE
    ground = None
    if spec.needs_ground:
        normal, offset = plane.plane(scene.ground_height)
        ground = (np.asarray(normal, dtype=float), float(offset))
    return SessionTrials(method=method, units=Units.IN, trial_ids=tuple(range(1, trials + 1)),
                         views=views, truth=np.stack([point] * trials), ground=ground)  # fmt: skip


def _angle(px: np.ndarray) -> float:
    d = px[1] - px[0]
    return math.degrees(math.atan2(d[1], d[0]))


def blundered(trials: SessionTrials, seed: int) -> tuple[SessionTrials, np.ndarray]:
    """The session with one pose's typed x off by 1 in in 20% of its trials, and which
    pose (1-based, 0: none) per trial."""
    rng = np.random.default_rng([seed, 54])
    which = np.zeros(len(trials), dtype=int)
    views = []
    for i, row in enumerate(trials.views):
        if rng.random() < BLUNDER_SHARE:
            k = int(rng.integers(len(row)))
            which[i] = k + 1
            off = np.array([BLUNDER_IN * rng.choice([-1.0, 1.0]), 0.0, 0.0])
            row = [dataclasses.replace(v, t_grid=v.t_grid + off) if j == k else v
                   for j, v in enumerate(row)]  # fmt: skip
        views.append(row)
    return dataclasses.replace(trials, views=views), which


def run_pooled(sessions: list[SessionTrials], group: str) -> list[SessionEstimate]:
    """The run's two passes over one operator's sessions (see the module)."""
    return two_passes(sessions, group)[1]


def two_passes(
    sessions: list[SessionTrials], group: str
) -> tuple[list[SessionEstimate], list[SessionEstimate]]:
    """The run's first pass (each session alone, the anchor its only prior) and its second."""
    first = [estimate_session(s, EstimateOptions(), line_fits=False) for s in sessions]
    stats = [session_statistics(group, e.misclosure, e.tests) for e in first]
    priors = operator_priors(stats, NoiseModel().anchor())
    return first, [estimate_session(s, EstimateOptions(noise=NoiseModel(prior=p)),
                                    line_fits=False)
                   for s, p in zip(sessions, priors, strict=True)]  # fmt: skip


def honesty(e: SessionEstimate) -> pd.DataFrame:
    """Per trial: ok, inside its 95% region, NEES/dof, its largest semi-axis, flagged,
    the pose named."""
    rep = reported(e)
    cols = uncertainty_columns(rep.error, rep.cov)
    tests = e.tests
    T = len(e.trials)
    return pd.DataFrame({
        "ok": e.estimates.status == "ok", "within": cols["within95"],
        "nees": cols["nees"] / np.maximum(cols["nees_dof"], 1), "axis": cols["semiaxis95"],
        "flagged": tests.flagged if tests else np.zeros(T, bool),
        "named": tests.pose if tests else np.zeros(T, int),
        "truth": [tests.by(i) == "truth" for i in range(T)] if tests else np.zeros(T, bool),
    })  # fmt: skip


def given(placing: float) -> EstimateOptions:
    """The regions with the placing multiplier given exactly: the truth's, ``placing^2``."""
    factor = VarianceFactor(sigma0_sq=math.nan, dof=0, placing_variance=placing**2,
                            sources="the truth")  # fmt: skip
    return EstimateOptions(noise=NoiseModel(factor=factor))


def coverage_rows(n: int, seed: int, operators: int = OPERATORS) -> pd.DataFrame:
    """Per cell (method, placing, size): ``operators`` operators of ``n`` sessions each,
    every operator's multiplier learned from their own sessions alone (a run of theirs)."""
    rows = []
    for method in METHODS:
        for placing in PLACINGS:
            for size in SIZES:
                s0 = seed + 100_000 * METHODS.index(method) + 1000 * size + int(10 * placing)
                for j in range(operators):
                    ks = range(j * n, (j + 1) * n)
                    sessions = [session(method, s0 + 7919 * k, size, placing) for k in ks]
                    group = operator_group(f"bench operator {j + 1}", method)
                    first, pooled = two_passes(sessions, group)
                    for k, s, e, e0 in zip(ks, sessions, pooled, first, strict=True):
                        rows.append(_coverage_frame(s, e, e0, placing, j, k))
    return pd.concat(rows, ignore_index=True)


def _coverage_frame(s: SessionTrials, e: SessionEstimate, alone: SessionEstimate,
                    placing: float, operator: int, k: int) -> pd.DataFrame:  # fmt: skip
    """One session's ok trials: inside their regions by each rule (``alone``: the run's
    first pass), NEES, the region's size."""
    a = honesty(e)
    b = honesty(alone)
    c = honesty(estimate_session(s, PLAIN, line_fits=False))
    d = honesty(estimate_session(s, given(placing), line_fits=False))
    ok = a["ok"]
    return pd.DataFrame({
        "method": str(s.method), "placing": placing, "size": len(s),
        "operator": operator, "session": k,
        "within": a["within"][ok], "alone": b["within"][ok],
        "typed": c["within"][ok], "given": d["within"][ok],
        "nees": a["nees"][ok],
        "ratio": (a["axis"] / c["axis"])[ok],
        "lam": e.factor.placing_variance if e.factor else 1.0,
        "dof": e.factor.variance_dof if e.factor else math.inf,
    })  # fmt: skip


def cluster_interval(h: pd.DataFrame, column: str = "within", draws: int = BOOT_DRAWS,
                     seed: int = 0) -> tuple[float, float]:  # fmt: skip
    """The 95% interval of a cell's mean ``column`` by a two-stage cluster bootstrap.

    The trials of one operator share that operator's multiplier estimate, and those of one
    session its misclosures: operators are drawn with replacement, then each drawn
    operator's sessions with replacement, and the trials of a drawn session come whole.
    """
    rng = np.random.default_rng(seed)
    per = h.groupby(["operator", "session"], sort=True)[column].agg(["sum", "count"])
    owners = per.index.get_level_values("operator").to_numpy()
    ops = np.unique(owners)
    sums, counts = per["sum"].to_numpy(float), per["count"].to_numpy(float)
    members = [np.flatnonzero(owners == o) for o in ops]
    num, den = np.zeros(draws), np.zeros(draws)
    for r, pick in enumerate(rng.integers(len(ops), size=(draws, len(ops)))):
        rows = np.concatenate([m[rng.integers(len(m), size=len(m))] for m in
                               (members[p] for p in pick)])  # fmt: skip
        num[r], den[r] = sums[rows].sum(), counts[rows].sum()
    lo, hi = np.quantile(num / den, [0.025, 0.975])
    return float(lo), float(hi)


def blunder_rows(n: int, seed: int, poses: int, methods: tuple[Method, ...] = METHODS,
                 sizes: tuple[int, ...] = SIZES, *, one_target: bool = True,
                 operators: int = 1) -> pd.DataFrame:  # fmt: skip
    """Blundered sessions' trials, ``n`` sessions a size split among ``operators`` (each a
    run of their own); without ``one_target`` each trial records its own truth (1e-6 in
    apart: the session is no one target, only each trial's misclosure can see its blunder)
    and the blunder-free sessions are not run (no ``ratio``). ``ratio``: a trial's region
    over the same session's with every trial typed right; ``absent``: over the same
    session's with the blundered trials left out (what the blunder itself costs, beyond its
    trial's information)."""
    rows = []
    for method in methods:
        for size in sizes:
            s0 = seed + 500_000 + 100_000 * METHODS.index(method) + 1000 * size + poses
            for j in range(operators):
                ks = range(j * n // operators, (j + 1) * n // operators)
                clean = [session(method, s0 + 7919 * k, size, 1.0, poses) for k in ks]
                if not one_target:
                    clean = [apart(s) for s in clean]
                made = [blundered(s, s0 + k) for k, s in zip(ks, clean, strict=True)]
                group = operator_group(f"bench operator {j + 1}", method)
                with_b = run_pooled([m for m, _ in made], group)
                without = run_pooled(clean, group) if one_target else with_b
                gone = [dataclasses.replace(s, views=[[] if w else v for v, w in
                                                      zip(s.views, which, strict=True)])
                        for s, (_, which) in zip(clean, made, strict=True)]  # fmt: skip
                absent = run_pooled(gone, group) if one_target else with_b
                for (_, which), e, e0, e1 in zip(made, with_b, without, absent, strict=True):
                    a, b, c = honesty(e), honesty(e0), honesty(e1)
                    ok = a["ok"] & b["ok"]
                    rows.append(pd.DataFrame({
                        "method": str(method), "size": size, "poses": poses, "operator": j,
                        "blunder": which[ok] > 0, "flagged": a["flagged"][ok],
                        "truth": a["truth"][ok],
                        "named": a["named"][ok], "right": (a["named"] == which)[ok],
                        "within": a["within"][ok], "ratio": (a["axis"] / b["axis"])[ok],
                        "absent": (a["axis"] / c["axis"].where(c["ok"]))[ok],
                        "seen": seen(e, which)[ok],
                    }))  # fmt: skip
    return pd.concat(rows, ignore_index=True)


def median_interval(h: pd.DataFrame, column: str, draws: int = BOOT_DRAWS,
                    seed: int = 0) -> tuple[float, float]:  # fmt: skip
    """The 95% interval of the median of ``column`` over ``h``'s trials, its operators drawn
    with replacement (an operator's trials share its multiplier: they move together)."""
    rng = np.random.default_rng(seed)
    # an operator is one per size and index (each size's sessions are runs of their own)
    groups = [g[column].dropna().to_numpy(float) for _, g in h.groupby(["size", "operator"])]
    medians = [np.median(np.concatenate([groups[i] for i in pick]))
               for pick in rng.integers(len(groups), size=(draws, len(groups)))]  # fmt: skip
    lo, hi = np.quantile(medians, [0.025, 0.975])
    return float(lo), float(hi)


def apart(trials: SessionTrials) -> SessionTrials:
    """The session with each trial's truth its own (1e-6 in apart): no one target."""
    shift = 1e-6 * np.arange(len(trials))[:, None, None] * np.array([1.0, 0.0, 0.0])
    return dataclasses.replace(trials, truth=trials.truth + shift)


def seen(e: SessionEstimate, which: np.ndarray) -> np.ndarray:
    """Per trial: whether its blunder is observable in its own misclosure (its
    noncentrality there at least what Baarda's test at its level detects with 80% power on
    the trial's dof); False for a clean trial."""
    m, out = e.misclosure, np.zeros(len(which), dtype=bool)
    if m is None:
        return out
    lam = e.factor.placing_variance if e.factor else 1.0
    for i in np.flatnonzero(which > 0):
        d = 1.0 + (lam - 1.0) * m.placing_share[i]
        nc = float((m.bias[i, which[i] - 1, 0] ** 2 / np.where(d > 0, d, np.inf)).sum())
        if m.dof[i] > 0:
            out[i] = nc >= _detectable(int(m.dof[i]))
    return out


def _detectable(dof: int) -> float:
    """The noncentrality Baarda's test at its level on ``dof`` detects 80% of the time."""
    cut = special.chdtri(dof, BAARDA_LEVEL)
    return float(optimize.brentq(lambda x: special.chndtr(cut, dof, x) - 0.2, 0.0, 1e3))


def report_coverage(t: pd.DataFrame) -> list[str]:
    print("coverage of the truth by the 95% regions (ok trials); each cell several operators, "
          "each operator's multiplier from their own sessions; 95% interval: a cluster "
          "bootstrap over operators, then their sessions")  # fmt: skip
    print(f"{'method':<8}{'placing':>8}{'size':>6}{'trials':>8}{'pooled':>8}{'interval':>15}"
          f"{'alone':>8}{'typed':>8}{'given':>8}{'NEES/dof':>9}{'region/typed':>13}"
          f"{'lambda':>8}{'its dof':>8}")  # fmt: skip
    missed, lo, hi = [], *COVERAGE_TARGET
    widths: list[str] = []
    for (method, placing), g in t.groupby(["method", "placing"], sort=False):
        for size, h in g.groupby("size"):
            a, b = cluster_interval(h)
            print(f"{method:<8}{placing:>7.1f}x{size:>6}{len(h):>8}{h['within'].mean():>8.1%}"
                  f"{f'{a:.1%}-{b:.1%}':>15}"
                  f"{h['alone'].mean():>8.1%}{h['typed'].mean():>8.1%}"
                  f"{h['given'].mean():>8.1%}{h['nees'].mean():>9.2f}"
                  f"{h['ratio'].median():>13.2f}{h['lam'].median():>8.2f}"
                  f"{h['dof'].median():>8.0f}")  # fmt: skip
            # a cell misses where its whole interval lies outside the band
            if b < lo or a > hi:
                cover = h["within"].mean()
                missed.append(f"{method} at {placing:g}x typed, {size} trials a session: "
                              f"regions cover {cover:.1%} ({a:.1%}-{b:.1%})")  # fmt: skip
            # typed right: a size's median width misses, as its coverage, where its whole
            # interval lies above (one cell's median rests on its few operators' multipliers:
            # 2-trial ground read 1.13 at one seed, 0.95-1.12 at 19 others; r8 curve lane)
            width = median_interval(h, "ratio") if placing == 1.0 else (np.nan, np.nan)
            if width[0] > TYPED_WIDER:
                missed.append(f"{method} typed right, {size} trials a session: regions "
                              f"{h['ratio'].median():.2f}x the typed ({width[0]:.2f}-"
                              f"{width[1]:.2f})")  # fmt: skip
            elif placing == 1.0:
                widths.append(f"{method} typed right, {size} trials: {h['ratio'].median():.2f}x"
                              f" ({width[0]:.2f}-{width[1]:.2f})")  # fmt: skip
        cover, alone, typed = g["within"].mean(), g["alone"].mean(), g["typed"].mean()
        print(f"{method:<8}{placing:>7.1f}x{'all':>6}{len(g):>8}{cover:>8.1%}{'':>15}"
              f"{alone:>8.1%}{typed:>8.1%}{g['given'].mean():>8.1%}{g['nees'].mean():>9.2f}"
              f"{g['ratio'].median():>13.2f}")  # fmt: skip
        if not lo <= cover <= hi:
            missed.append(f"{method} at {placing:g}x typed: regions cover {cover:.1%}")
        if placing == 1.0 and g["ratio"].median() > TYPED_WIDER:
            missed.append(f"{method} typed right: regions {g['ratio'].median():.2f}x the typed")
    print("typed right, each size's median region over the typed sigma's with its 95% interval "
          "(operators resampled): " + "; ".join(widths))  # fmt: skip
    return missed


def report_blunders(t: pd.DataFrame) -> list[str]:
    operators = t["operator"].nunique()
    print(f"\na {BLUNDER_IN:g} in blunder (one pose's typed x) in {BLUNDER_SHARE:.0%} of the "
          f"trials, typed right otherwise; {operators} operators a size; the clean trials' "
          "regions over the same sessions' typed right, and with the blundered trials "
          "absent (95% interval of its median, operators resampled)")  # fmt: skip
    print(f"{'method':<8}{'size':>6}{'blundered':>10}{'flagged':>9}{'by truth':>9}{'clean':>7}"
          f"{'flagged':>9}{'vs typed right':>15}{'vs absent':>10}{'interval':>14}"
          f"{'90th':>7}{'unflagged cover':>16}{'all cover':>10}")  # fmt: skip
    missed, lo, hi = [], *COVERAGE_TARGET
    for method, g in t.groupby("method", sort=False):
        for size, h in [*g.groupby("size"), ("all", g)]:
            b, c = h[h["blunder"]], h[~h["blunder"]]
            u = h[~h["flagged"]]
            low, high = median_interval(c, "absent")
            print(f"{method:<8}{size!s:>6}{len(b):>10}{b['flagged'].mean():>9.1%}"
                  f"{b['truth'].mean():>9.1%}{len(c):>7}"
                  f"{c['flagged'].mean():>9.1%}{c['ratio'].median():>15.3f}"
                  f"{c['absent'].median():>10.3f}{f'{low:.3f}-{high:.3f}':>14}"
                  f"{c['absent'].quantile(0.9):>7.3f}{u['within'].mean():>16.1%}"
                  f"{h['within'].mean():>10.1%}")  # fmt: skip
        b, c, u = g[g["blunder"]], g[~g["blunder"]], g[~g["flagged"]]
        if b["flagged"].mean() < FLAGGED_LEAST:
            missed.append(f"{method}: {b['flagged'].mean():.1%} of blundered trials flagged")
        if c["flagged"].mean() > FALSE_MOST:
            missed.append(f"{method}: {c['flagged'].mean():.1%} of clean trials flagged")
        low, _high = median_interval(c, "absent")
        if low > CLEAN_MEDIAN or c["absent"].quantile(0.9) > CLEAN_P90:
            missed.append(f"{method}: clean trials' regions widened by the blunders")
        if not lo <= u["within"].mean() <= hi:
            missed.append(f"{method}: unflagged trials cover {u['within'].mean():.1%}")
    return missed


def multiplier_rows(n: int, seed: int, size: int = MULTIPLIER_SIZE) -> pd.DataFrame:
    """Per method and placing error: the multiplier pooled over ``n`` sessions of ``size``
    trials of one operator, as :func:`operator_priors` pools them (flagged trials out, the
    rest's likelihood truncated where the test keeps them), against its truth
    ``placing^2``, with the degrees of freedom the data give it."""
    rows = []
    for method in METHODS:
        for placing in PLACINGS:
            s0 = seed + 900_000 + 100_000 * METHODS.index(method) + int(10 * placing)
            options = EstimateOptions()
            stats = [session_statistics("", estimate_session(
                        session(method, s0 + 7919 * k, size, placing), options,
                        line_fits=False).misclosure) for k in range(n)]  # fmt: skip
            M = max(s.share.shape[1] for s in stats)
            pad = [np.pad(s.share, ((0, 0), (0, M - s.share.shape[1]))) for s in stats]
            z2 = [np.pad(s.z2, ((0, 0), (0, M - s.z2.shape[1]))) for s in stats]
            chi2, dof = (
                np.concatenate([s.chi2 for s in stats]),
                np.concatenate([s.dof for s in stats]),
            )
            anchor = NoiseModel().anchor()
            flags = flag_trials(chi2, dof, np.concatenate(pad), np.concatenate(z2), anchor)
            # the data's alone: an anchor of no weight
            post = posterior(flags.kept.sum(axis=0), PlacingPrior(scale=1.0, dof=1e-9, source=""),
                             None, flags.info.sum(axis=0))  # fmt: skip
            rows.append({"method": str(method), "placing": placing,
                         "ratio": post.scale / placing**2, "dof": post.information,
                         "posterior_dof": post.dof,
                         "trials": int((~flags.flagged & (dof > 0)).sum())})  # fmt: skip
    return pd.DataFrame(rows)


def report_multiplier(t: pd.DataFrame, n: int) -> None:
    # the 1-sigma is the posterior's own (its shape's dof): the truncated likelihood the
    # estimate rests on holds less than the kept trials' information (``dof``), about 0.56
    # of it for a point at 3x, where 10 seeds scatter 0.044 and sqrt(2 / dof) says 0.027
    print(f"\nthe multiplier pooled over {n} sessions of {MULTIPLIER_SIZE} trials, over its "
          "truth (dof: the kept trials' information; its 1-sigma: sqrt(2 / the posterior's "
          "own dof), the robust stage's truncated likelihood's)")  # fmt: skip
    print(f"{'method':<8}{'placing':>8}{'trials':>8}{'dof':>8}{'lambda/truth':>13}{'1-sigma':>9}")
    for r in t.to_dict("records"):
        print(f"{r['method']:<8}{r['placing']:>7.1f}x{r['trials']:>8}{r['dof']:>8.0f}"
              f"{r['ratio']:>13.3f}{math.sqrt(2 / float(r['posterior_dof'])):>9.3f}")  # fmt: skip


def report_alone(t: pd.DataFrame) -> None:
    print("\nthe same with each trial its own target (only its misclosure and its truth can "
          "see a blunder; by truth: flagged by its truth alone; "
          "seen: one its trial's poses can check, Baarda's test at "
          f"{BAARDA_LEVEL:.1%} catching it 80% of the time)")  # fmt: skip
    print(f"{'method':<8}{'blundered':>10}{'flagged':>9}{'by truth':>9}{'seen':>7}"
          f"{'of those flagged':>17}{'clean flagged':>14}{'by truth':>9}"
          f"{'unflagged cover':>16}{'all cover':>10}")  # fmt: skip
    for method, g in t.groupby("method", sort=False):
        b, c, u = g[g["blunder"]], g[~g["blunder"]], g[~g["flagged"]]
        s = b[b["seen"]]
        print(f"{method:<8}{len(b):>10}{b['flagged'].mean():>9.1%}{b['truth'].mean():>9.1%}"
              f"{len(s) / max(len(b), 1):>7.0%}"
              f"{s['flagged'].mean():>17.1%}{c['flagged'].mean():>14.1%}"
              f"{c['truth'].mean():>9.1%}{u['within'].mean():>16.1%}"
              f"{g['within'].mean():>10.1%}")  # fmt: skip


def report_naming(t: pd.DataFrame) -> None:
    print("\nwhich pose: blundered trials flagged, the pose named, named right")
    print(f"{'method':<8}{'poses':>6}{'blundered':>10}{'flagged':>9}{'named':>8}{'right':>8}")
    for (method, poses), g in t.groupby(["method", "poses"], sort=False):
        b = g[g["blunder"]]
        f = b[b["flagged"]]
        named = f[f["named"] > 0]
        print(f"{method:<8}{poses:>6}{len(b):>10}{b['flagged'].mean():>9.1%}"
              f"{len(named) / max(len(f), 1):>8.1%}{named['right'].mean():>8.1%}")  # fmt: skip


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sessions", type=int, default=20, help="each operator's")
    parser.add_argument("--operators", type=int, default=OPERATORS, help="a cell's")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--multiplier-sessions", type=int, default=200)
    parser.add_argument("--write-docs", action="store_true")
    args = parser.parse_args()
    started = time.perf_counter()
    print(f"{args.operators} operators of {args.sessions} sessions each per cell, 3 poses a "
          f"trial, typed {TYPED_IN:g} in\n")  # fmt: skip
    missed = report_coverage(coverage_rows(args.sessions, args.seed, args.operators))
    report_multiplier(multiplier_rows(args.multiplier_sessions, args.seed),
                      args.multiplier_sessions)  # fmt: skip
    n = args.sessions * args.operators  # the blunders': one operator's n sessions
    missed += report_blunders(blunder_rows(n, args.seed, 3, operators=args.operators))
    report_alone(blunder_rows(n, args.seed, 3, one_target=False))
    four = blunder_rows(n, args.seed, 4, (Method.POINT, Method.GROUND), (4,))
    three = blunder_rows(n, args.seed, 3, (Method.POINT, Method.GROUND), (4,))
    report_naming(pd.concat([three, four], ignore_index=True))
    return finished(started, missed)


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
