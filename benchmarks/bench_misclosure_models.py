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
import contextlib
import dataclasses
import itertools
import sys
import time
from collections.abc import Iterator
from pathlib import Path

import numpy as np
from doc_figures import finished, run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]
from scipy import special

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

import bench_noise as bench  # type: ignore[import-not-found]  # noqa: E402

import twopose.uncertainty.session_noise as session_noise  # noqa: E402
from recorder.simulate.one_camera import draw_trial_poses  # noqa: E402
from twopose.camera.model import rotation_from_angles_deg  # noqa: E402
from twopose.methods.specs import Method  # noqa: E402
from twopose.sim.scene import Scene  # noqa: E402
from twopose.solve.estimate import EstimateOptions  # noqa: E402
from twopose.solve.nview import projection_matrices, triangulate_points  # noqa: E402
from twopose.solve.session import SessionEstimate, SessionTrials, estimate_session  # noqa: E402
from twopose.uncertainty.misclosure_models import ray_conditions  # noqa: E402
from twopose.uncertainty.noise import NoiseModel, PlacingPrior  # noqa: E402
from twopose.uncertainty.operator_pool import operator_priors  # noqa: E402
from twopose.uncertainty.propagate import PLACING, jacobians  # noqa: E402
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


@contextlib.contextmanager
def inputs_seen() -> Iterator[dict[str, np.ndarray]]:
    """The typed inputs and their covariance each session's misclosures are computed from."""
    seen: dict[str, np.ndarray] = {}
    names = vars(session_noise)  # the module's own binding (it imported the function)
    real = names["misclosures"]

    def spy(*args: object, **kwargs: object) -> object:
        seen["x0"], seen["C"] = np.asarray(args[1]), np.asarray(args[2])
        return real(*args, **kwargs)

    names["misclosures"] = spy
    try:
        yield seen
    finally:
        names["misclosures"] = real


def quadratic_form(x: np.ndarray, C: np.ndarray, intrinsics: np.ndarray) -> np.ndarray:
    """(R, 3N, 3N) a point trial's misclosure as a quadratic form in its typed translations'
    errors (in their sigmas), the views ``x`` (R, N, 9) consistent."""
    R, N, _ = x.shape

    def flat(v: np.ndarray) -> np.ndarray:
        intr = np.broadcast_to(intrinsics, (v.shape[0], *intrinsics.shape))
        P = projection_matrices(intr, rotation_from_angles_deg(v[..., 6:9]), v[..., 3:6])
        valid = np.ones(v.shape[:2], dtype=bool)
        X = triangulate_points(v[..., :2], P, valid=valid).point_grid  # the thesis' point
        return ray_conditions(v, X, P, valid).reshape(v.shape[0], 2 * N)

    J, _ = jacobians(flat, x, C, 2 * N)
    cov = np.einsum("rinj,rnjk,rlnk->ril", J, C, J)
    w, V = np.linalg.eigh(cov)
    keep = np.arange(2 * N)[None, :] >= 2 * N - (2 * N - 3)  # the redundancy's directions
    inv = np.einsum("rij,rj,rkj->rik", V, np.where(keep, 1.0 / np.where(keep, w, 1.0), 0.0), V)
    sigma = np.sqrt(np.diagonal(C[..., PLACING, PLACING], axis1=-2, axis2=-1))
    Jt = (J[..., PLACING] * sigma[:, None]).reshape(R, 2 * N, 3 * N)
    return np.asarray(np.einsum("rmi,rml,rlk->rik", Jt, inv, Jt))


def second_order(x0: np.ndarray, C: np.ndarray, intrinsics: np.ndarray) -> tuple[float, float]:
    """A point trial's misclosure's expectation at multiplier 1 (``tr S``) and its second
    order term when the cameras stand at the typed values plus the error,
    ``laplacian(tr S) / 2 + sum_ik d2 S_ik / dt_i dt_k`` (``S`` as the true translations
    move, in their sigmas; central differences of one sigma)."""
    N = x0.shape[0]
    D = 3 * N
    pairs = list(itertools.combinations(range(D), 2))
    steps = [np.zeros(D)] + [s * np.eye(D)[i] for i in range(D) for s in (1.0, -1.0)]
    steps += [a * np.eye(D)[i] + b * np.eye(D)[k] for i, k in pairs
              for a, b in ((1, 1), (1, -1), (-1, 1), (-1, -1))]  # fmt: skip
    sigma = np.sqrt(np.diagonal(C[:, PLACING, PLACING], axis1=-2, axis2=-1)).ravel()
    x = np.repeat(x0[None], len(steps), axis=0)
    x[..., PLACING] += (np.array(steps) * sigma).reshape(-1, N, 3)
    R0 = rotation_from_angles_deg(x0[:, 6:9])
    X = triangulate_points(x0[None, :, :2], projection_matrices(intrinsics, R0, x0[:, 3:6])[None])
    P = projection_matrices(np.broadcast_to(intrinsics, (len(steps), N, 4)),
                            rotation_from_angles_deg(x[..., 6:9]), x[..., 3:6])  # fmt: skip
    h = np.einsum("rnij,j->rni", P, np.append(X.point_grid[0], 1.0))
    x[..., :2] = h[..., :2] / h[..., 2:3]  # each camera's view of the one point: consistent
    S = quadratic_form(x, np.repeat(C[None], len(steps), axis=0), intrinsics)
    trace = np.einsum("rii->r", S)
    term = 0.5 * sum(trace[1 + 2 * i] - 2 * trace[0] + trace[2 + 2 * i] for i in range(D))
    term += sum(S[1 + 2 * i, i, i] - 2 * S[0, i, i] + S[2 + 2 * i, i, i] for i in range(D))
    for q, (i, k) in enumerate(pairs):
        pp, pm, mp, mm = S[1 + 2 * D + 4 * q : 5 + 2 * D + 4 * q, i, k]
        term += 2 * (pp - pm - mp + mm) / 4
    return float(trace[0]), float(term)


def predicted(placing: float, n: int, seed: int) -> float:
    """The second-order term's share of the expectation, ``lambda^2 b / (lambda tr S)``,
    over the first ``n`` sessions' trials."""
    lam, first, second = placing**2, 0.0, 0.0
    with inputs_seen() as seen:
        for k in range(n):
            s = bench.session(Method.POINT, seed + 7919 * k, SIZE, placing)
            estimate_session(s, EstimateOptions(), line_fits=False)
            for t, row in enumerate(s.views):
                intrinsics = np.stack([v.intrinsics for v in row])
                trace, term = second_order(seen["x0"][t], seen["C"][t], intrinsics)
                first, second = first + lam * trace, second + lam**2 * term
    return second / first


def report_models(n: int, seed: int, predict: int) -> None:
    print(f"the misclosure over its expectation at the true multiplier, {n} sessions of {SIZE} "
          "point trials (3 poses) a placing error; the same placing errors (typed less true) "
          "with the camera where the simulator placed it (the rays carry the error) and at the "
          "typed value (the analysis' model); their difference paired by session; predicted: "
          f"the second-order term over the first {predict} sessions' trials")  # fmt: skip
    print(f"{'placing':>8}{'directions':>11}{'simulator':>10}{'model':>8}{'1-sigma':>9}"
          f"{'difference':>11}{'1-sigma':>9}{'predicted':>10}")  # fmt: skip
    for placing in PLACINGS:
        a = misclosure_ratios(placing, n, seed, draw_trial_poses)
        b = misclosure_ratios(placing, n, seed, camera_at_typed)
        ra, rb = a[:, 0].sum() / a[:, 1].sum(), b[:, 0].sum() / b[:, 1].sum()
        # the ratio of sums' difference, linearised per session (a paired delta method)
        d = a[:, 0] / a[:, 1].mean() - b[:, 0] / b[:, 1].mean()
        directions = 3 * n * SIZE
        print(f"{placing:>7.1f}x{directions:>11}{ra:>10.3f}{rb:>8.3f}"
              f"{np.sqrt(2 / directions):>9.3f}{ra - rb:>+11.3f}"
              f"{d.std(ddof=1) / np.sqrt(n):>9.3f}"
              f"{predicted(placing, predict, seed):>+10.3f}")  # fmt: skip


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
    parser.add_argument("--predict-sessions", type=int, default=12,
                        help="the second-order term's (each trial about 0.3 s)")  # fmt: skip
    parser.add_argument("--operators-sessions", type=int, default=20, help="a line operator's")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--write-docs", action="store_true")
    args = parser.parse_args()
    started = time.perf_counter()
    report_models(args.sessions, args.seed, args.predict_sessions)
    report_line(args.operators_sessions, args.seed)
    return finished(started, [])


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
