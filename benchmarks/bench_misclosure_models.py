"""Two of issue 54's open cells traced (``benchmarks/bench_noise.py``'s sessions):
a point's multiplier low at 3x the typed placing, and a blunder that still widens the
clean trial of a two-trial line session.

    .venv/bin/python benchmarks/bench_misclosure_models.py [--sessions 200] [--seed 0]
        [--write-docs]

**The misclosure under two placing models.** The simulator places the laptop about each
typed value (``recorder.simulate.one_camera.draw_trial_poses``: the typed on the pose
lattice, every typed height 0, the true pose the typed plus the placing error), so the
camera that saw the target stood at the typed value plus the error, and the rays'
directions carry that error. The analysis' noise model has it the other way (the typed
value the true one plus an error independent of the geometry, the classical model): under
it the misclosure's chi-square at the true multiplier averages its degrees of freedom.
Per placing error, ``--sessions`` sessions of 5 point trials (3 poses each), the same
true poses and detections three ways: the simulator's typed values; each typed value
the true less a fresh error of the same sigma (the analysis' model); and only the typed
height drawn so, x and z the simulator's. The column is the misclosures' summed squared
components over their expectation at the true multiplier, ``sum(1 + (lambda - 1) beta)``
(``twopose.uncertainty.misclosure``), with its 1-sigma ``sqrt(2 / directions)``.

**The two-trial line sessions' blunder.** ``bench_noise``'s first blunder table, its line
sessions of two trials (4 operators of 20, a 1 in blunder in 20% of trials, typed right
otherwise): the clean trial's region over the same sessions' with the blundered trials
absent, as the run's two passes give it, and with a third pass that leaves out of each
operator's pool the trials the second pass's truth test flagged (the truth tested in
regions of the operator's multiplier, not of the session's alone); and what reached the
pool: the trials the truth alone flagged, their misclosures' p-values, the operators'
priors (scale and dof, with the blunders over without).

No targets: a measurement (exit 0).
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np
from doc_figures import finished, run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]
from scipy import special

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import bench_noise as bench  # type: ignore[import-not-found]  # noqa: E402

from recorder.simulate.one_camera import draw_trial_poses  # noqa: E402
from twopose.methods.specs import Method  # noqa: E402
from twopose.sim.scene import Scene  # noqa: E402
from twopose.solve.estimate import EstimateOptions  # noqa: E402
from twopose.solve.session import SessionEstimate, SessionTrials, estimate_session  # noqa: E402
from twopose.uncertainty.noise import NoiseModel, PlacingPrior  # noqa: E402
from twopose.uncertainty.placing_variance import operator_priors  # noqa: E402
from twopose.uncertainty.session_noise import operator_group, session_statistics  # noqa: E402

FIGURE = "misclosure_models.txt"
PLACINGS = (1.0, 3.0)
SIZE, LINE_SIZE, OPERATORS = 5, 2, 4


def camera_at_typed(scene: Scene, method: Method, poses: int, rng: np.random.Generator
                    ) -> list[tuple[np.ndarray, ...]]:  # fmt: skip
    """The simulator's poses with the camera at the typed value and the typed value off it
    by the same error the other way (typed less true: the simulator's): the analysis'
    model, the error vector the same, the rays' directions no longer carrying it."""
    out: list[tuple[np.ndarray, ...]] = []
    for typed, r_typed, t_true, r_true in draw_trial_poses(scene, method, poses, rng):
        out.append((typed - (t_true - typed), r_typed, typed, r_true))
    return out


def misclosure_ratios(placing: float, n: int, seed: int, draw: bench.Draw) -> np.ndarray:
    """(n, 2) per session of :data:`SIZE` point trials: the misclosures' summed squared
    components, and their expectation at the true multiplier."""
    lam, out = placing**2, np.zeros((n, 2))
    for k in range(n):
        s = bench.session(Method.POINT, seed + 7919 * k, SIZE, placing, draw=draw)
        m = estimate_session(s, EstimateOptions(), line_fits=False).misclosure
        assert m is not None
        use = (m.dof > 0)[:, None] & (m.placing_share > 0)
        out[k] = m.z2[use].sum(), (1.0 + (lam - 1.0) * m.placing_share)[use].sum()
    return out


def report_models(n: int, seed: int) -> None:
    print(f"the misclosure over its expectation at the true multiplier, {n} sessions of {SIZE} "
          "point trials (3 poses) a placing error; the same placing errors (typed less true) "
          "with the camera where the simulator placed it (the rays carry the error) and at the "
          "typed value (the analysis' model); their difference paired by session")  # fmt: skip
    print(f"{'placing':>8}{'directions':>11}{'simulator':>10}{'model':>8}{'1-sigma':>9}"
          f"{'difference':>11}{'1-sigma':>9}")  # fmt: skip
    for placing in PLACINGS:
        a = misclosure_ratios(placing, n, seed, draw_trial_poses)
        b = misclosure_ratios(placing, n, seed, camera_at_typed)
        ra, rb = a[:, 0].sum() / a[:, 1].sum(), b[:, 0].sum() / b[:, 1].sum()
        # the ratio of sums' difference, linearised per session (a paired delta method)
        d = a[:, 0] / a[:, 1].mean() - b[:, 0] / b[:, 1].mean()
        directions = 3 * n * SIZE
        print(f"{placing:>7.1f}x{directions:>11}{ra:>10.3f}{rb:>8.3f}"
              f"{np.sqrt(2 / directions):>9.3f}{ra - rb:>+11.3f}"
              f"{d.std(ddof=1) / np.sqrt(n):>9.3f}")  # fmt: skip


def third_pass(sessions: list[SessionTrials], first: list[SessionEstimate],
               second: list[SessionEstimate], group: str
               ) -> tuple[list[SessionEstimate], list[PlacingPrior | None]]:  # fmt: skip
    """The sessions again, each operator's pool without the trials the second pass's truth
    test flagged."""
    stats = []
    for e1, e2 in zip(first, second, strict=True):
        m, tests = e1.misclosure, e2.tests
        assert m is not None
        assert tests is not None
        off = np.array([tests.by(i) == "truth" for i in range(len(e2.trials))])
        m = dataclasses.replace(m, dof=np.where(off, 0, m.dof), chi2=np.where(off, np.nan, m.chi2))
        stats.append(session_statistics(group, m, e1.tests))
    priors = operator_priors(stats, NoiseModel().anchor())
    return [estimate_session(s, EstimateOptions(noise=NoiseModel(prior=p)), line_fits=False)
            for s, p in zip(sessions, priors, strict=True)], priors  # fmt: skip


def line_rows(n: int, seed: int) -> dict[str, list[float]]:
    """Per clean trial of a blundered two-trial line session: its region over the one with
    the blundered trials absent (two passes, three); per truth-flagged blunder its
    misclosure's p-value; per session its prior's scale and dof over the absent's."""
    s0 = seed + 500_000 + 100_000 * bench.METHODS.index(Method.LINE) + 1000 * LINE_SIZE + 3
    out: dict[str, list[float]] = {k: [] for k in ("two", "three", "p", "scale", "dof")}
    for j in range(OPERATORS):
        ks = range(j * n, (j + 1) * n)
        clean = [bench.session(Method.LINE, s0 + 7919 * k, LINE_SIZE, 1.0) for k in ks]
        made = [bench.blundered(s, s0 + k) for k, s in zip(ks, clean, strict=True)]
        sessions = [m for m, _ in made]
        gone = [dataclasses.replace(s, views=[[] if w else v for v, w in
                                              zip(s.views, which, strict=True)])
                for s, (_, which) in zip(clean, made, strict=True)]  # fmt: skip
        group = operator_group(f"bench operator {j + 1}", Method.LINE)
        first, second = bench.two_passes(sessions, group)
        first_absent, absent = bench.two_passes(gone, group)
        third, _ = third_pass(sessions, first, second, group)
        for (_, which), e, e0, e3 in zip(made, second, absent, third, strict=True):
            _clean_ratios(out, which, e, e0, e3)
        _pool_rows(out, first, second, first_absent, group)
    return out


def _clean_ratios(out: dict[str, list[float]], which: np.ndarray, e: SessionEstimate,
                  e0: SessionEstimate, e3: SessionEstimate) -> None:  # fmt: skip
    a, c, d = bench.honesty(e), bench.honesty(e0), bench.honesty(e3)
    for i in np.flatnonzero((which == 0) & a["ok"].to_numpy() & c["ok"].to_numpy()):
        out["two"].append(float(a["axis"][i] / c["axis"][i]))
        out["three"].append(float(d["axis"][i] / c["axis"][i]))


def _pool_rows(out: dict[str, list[float]], first: list[SessionEstimate],
               second: list[SessionEstimate], first_absent: list[SessionEstimate],
               group: str) -> None:  # fmt: skip
    """What reached one operator's pool: the truth-flagged trials' misclosure p-values,
    each session's prior over the one with the blundered trials absent."""
    for e1, e2 in zip(first, second, strict=True):
        m, tests = e1.misclosure, e2.tests
        assert m is not None
        assert tests is not None
        for i in range(len(e2.trials)):
            if tests.by(i) == "truth" and m.dof[i] > 0:
                out["p"].append(float(special.chdtrc(m.dof[i], m.chi2[i])))
    anchor = NoiseModel().anchor()
    with_b = operator_priors([session_statistics(group, e.misclosure, e.tests) for e in first],
                             anchor)  # fmt: skip
    without = operator_priors([session_statistics(group, e.misclosure, e.tests)
                               for e in first_absent], anchor)  # fmt: skip
    for p1, p0 in zip(with_b, without, strict=True):
        if p1 is not None and p0 is not None:
            out["scale"].append(p1.scale / p0.scale)
            out["dof"].append(p1.dof / p0.dof)


def report_line(n: int, seed: int) -> None:
    rows = line_rows(n, seed)
    two, three = np.array(rows["two"]), np.array(rows["three"])
    print(f"\nline sessions of {LINE_SIZE} trials, a 1 in blunder in 20% of trials, {OPERATORS} "
          f"operators of {n}: the clean trials' regions over the same sessions' with the "
          "blundered trials absent")  # fmt: skip
    print(f"{'the run':<58}{'clean':>6}{'median':>8}{'90th':>7}{'max':>7}")
    for name, r in (
        ("two passes (as the run does)", two),
        ("a third pass: the second pass's truth flags out of the pool", three),
    ):
        print(f"{name:<58}{len(r):>6}{np.median(r):>8.3f}{np.quantile(r, 0.9):>7.3f}"
              f"{r.max():>7.3f}")  # fmt: skip
    p, scale, dof = (np.array(rows[k]) for k in ("p", "scale", "dof"))
    print(
        f"trials the truth alone flagged, handed to their operator's pool: {len(p)}, their "
        f"misclosure's p-value median {np.median(p):.3f} (range {p.min():.3f}-{p.max():.3f})"
    )
    print(
        f"the sessions' priors with the blunders over without: scale median "
        f"{np.median(scale):.3f} (range {scale.min():.3f}-{scale.max():.3f}), dof median "
        f"{np.median(dof):.2f} (range {dof.min():.2f}-{dof.max():.2f})"
    )


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sessions", type=int, default=600, help="a placing error's")
    parser.add_argument("--operators-sessions", type=int, default=20, help="a line operator's")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--write-docs", action="store_true")
    args = parser.parse_args()
    started = time.perf_counter()
    report_models(args.sessions, args.seed)
    report_line(args.operators_sessions, args.seed)
    return finished(started, [])


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
