"""The rig's constants, estimated from each session's own ground truth (issue 15).

    .venv/bin/python benchmarks/bench_rig.py [--seeds 9] [--methods point ground] [--workers 2]

Simulated sessions of 15 trials in the thesis' geometry and typing (the thesis_* sample
sessions' poses: x or x-and-depth moves, 1/8 in typing, 0.04 in placing error, 5 frames),
each seed simulated twice: with the constants (mount rotation (0.8, -0.5, 0.3) deg, camera
offset (0.3, 0.2, 0.4) in, focal scale 1.03) and without. Per session, ``run
--rig-calibration loo`` (each trial corrected by constants selected and fitted without
it). A seed's RMSEs are over the trials the summary uses (ok, without a near-degeneracy
warning: the report's headline set) in both of its sessions, so both sessions are judged
on the same targets; coverage is over every ok trial. Targets:

1. with constants: the leave-one-out corrected RMSE <= 1.15x the RMSE of the same seed
   simulated without them;
2. without constants: the corrected RMSE <= 1.05x the uncorrected one;
3. the constants, fitted (mount, offset, focal) on all trials, within their 95% intervals
   of the truth (at least 90% of them);
4. the corrected estimates' 95% regions cover the truth in 90-99% of >= 500 trials (the
   default 9 seeds x 2 methods x 2 sessions x 15 trials = 540).

Then the real workflow, calibrate once and measure: for each seed, ``rig`` on the other
seeds' sessions with constants (``analysis.rig.calibrate.calibrate``, default selection),
applied to this seed's with ``run --rig``; its RMSE against the same base (target 1
again, reported beside the leave-one-out one, and the pooled RMSE per method).

Prints one line per session and a summary; exits 1 if a target is missed.
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from twopose.methods.specs import Method

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "sessions"))

from make_sessions import THESIS_POSES  # type: ignore[import-not-found]  # noqa: E402 - on sys.path at run time

from analysis.batch.runner import run  # noqa: E402
from analysis.results import AnalysisOptions  # noqa: E402
from analysis.rig.calibrate import calibrate  # noqa: E402
from analysis.session.metrics import used_trials  # noqa: E402
from recorder.simulate.one_camera import simulate_session  # noqa: E402
from twopose.rig.constants import RigConstants  # noqa: E402
from twopose.sim.scene import Scene  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "rig.txt"

RIG = RigConstants(
    mount_rotation_deg=(0.8, -0.5, 0.3), camera_offset=(0.3, 0.2, 0.4), focal_scale=1.03
)
TRUE_GROUPS = ["mount_rotation_deg", "camera_offset", "focal_scale"]


def rmse(values: np.ndarray) -> float:
    v = values[np.isfinite(values)]
    return float(np.sqrt(np.mean(v**2)))


@dataclass(frozen=True)
class SeedResult:
    """One (method, seed): its RMSEs, its trials' coverage and its constants' check."""

    method: str
    seed: int
    base: float  # without constants, uncorrected
    with_raw: float  # with constants, uncorrected
    loo_with: float
    loo_without: float
    covered: list[float]
    within: int
    fitted: int
    both: frozenset[int]  # the trials both sessions use

    def line(self) -> str:
        r1, r2 = self.loo_with / self.base, self.loo_without / self.base
        return (
            f"{self.method:6} {self.seed:4} {len(self.both):3}  {self.base:12.3f}  "
            f"{self.with_raw:9.3f}  {self.loo_with:8.3f} ({r1:.3f})           "
            f"{self.loo_without:8.3f} ({r2:.3f})"
        )

    @property
    def ok(self) -> bool:
        return self.loo_with <= 1.15 * self.base and self.loo_without <= 1.05 * self.base


def session_path(folder: Path, method: str, seed: int, name: str) -> Path:
    return folder / f"{method}_{seed}_{name}.mcap"


def simulate_pair(method: str, seed: int, folder: Path) -> dict[str, Path]:
    """The seed simulated with the constants and without, kept in ``folder``."""
    paths = {}
    for name, rig in (("with", RIG), ("without", RigConstants())):
        paths[name] = session_path(folder, method, seed, name)
        scene = Scene(poses=THESIS_POSES, systematic=rig)
        simulate_session(
            paths[name], method=Method(method), trials=15, frames=5, seed=100 + seed, scene=scene
        )
    return paths


def constants_within(path: Path) -> tuple[int, int]:
    """Of the true groups fitted on all the session's trials: how many scalars lie within
    their 95% interval of the truth, and how many were fitted."""
    fit, _ = calibrate([str(path)], TRUE_GROUPS)
    rows = [row for row in fit.rows(RIG) if row["fitted"]]
    within = sum(
        abs(float(r["value"]) - float(r["truth"])) <= 1.96 * float(r["sigma"])  # type: ignore[arg-type]
        for r in rows
    )
    return within, len(rows)


def one_seed(method: str, seed: int, folder: Path) -> SeedResult:
    """Simulate the seed with and without the constants; judge them (see the docstring)."""
    paths = simulate_pair(method, seed, folder)
    trials = run(list(paths.values()), None, options=AnalysisOptions(rig_calibration="loo")).trials
    by = {Path(str(s)).stem.rsplit("_", 1)[1]: g for s, g in trials.groupby("session")}
    # The trials the summary uses (ok, unwarned) in both sessions: one set of targets.
    both = set.intersection(*(set(used_trials(g)["trial"]) for g in by.values()))
    ok = {name: g[g["trial"].isin(both)] for name, g in by.items()}
    # Coverage is a property of every ok trial's region, warned ones' (wide) included.
    covered = [
        float(v) for g in by.values()
        for v in g[g["status"] == "ok"]["within95_rig"].astype(float)  # <NA>: NaN
        if np.isfinite(v)
    ]  # fmt: skip
    within, fitted = constants_within(paths["with"])
    return SeedResult(
        method,
        seed,
        rmse(ok["without"]["err"].to_numpy()),
        rmse(ok["with"]["err"].to_numpy()),
        rmse(ok["with"]["err_rig"].to_numpy()),
        rmse(ok["without"]["err_rig"].to_numpy()),
        covered,
        within,
        fitted,
        frozenset(int(t) for t in both),
    )


def calibrated_once(result: SeedResult, seeds: int, folder: Path) -> float:
    """The seed's session with constants corrected by ``rig`` on the other seeds' (the
    real workflow); its RMSE over the seed's common trials."""
    others = [
        str(session_path(folder, result.method, s, "with"))
        for s in range(seeds)
        if s != result.seed
    ]
    fit, _ = calibrate(others)
    path = session_path(folder, result.method, result.seed, "with")
    trials = run([path], None, options=AnalysisOptions(rig=fit.constants)).trials
    return rmse(trials[trials["trial"].isin(result.both)]["err"].to_numpy())


def pooled(results: list[SeedResult], attribute: str) -> float:
    """The RMSE over every seed's common trials."""
    squares = sum(len(r.both) * getattr(r, attribute) ** 2 for r in results)
    return float(np.sqrt(squares / sum(len(r.both) for r in results)))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=9)
    parser.add_argument("--methods", nargs="+", default=["point", "ground"])
    parser.add_argument("--workers", type=int, default=2)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        results = leave_one_out_table(args, Path(tmp))
        ok = summary(results)
        ok &= workflow_table(results, args.seeds, Path(tmp), args.workers)
    return 0 if ok else 1


def leave_one_out_table(args: argparse.Namespace, folder: Path) -> list[SeedResult]:
    jobs = [(m, s, folder) for m in args.methods for s in range(args.seeds)]
    print("method seed   n  rmse_without  rmse_with  with_loo (ratio, <= 1.15)", end="")
    print("  without_loo (ratio, <= 1.05)")
    results = []
    with ProcessPoolExecutor(args.workers) as pool:
        for result in pool.map(one_seed, *zip(*jobs, strict=True)):
            print(result.line(), flush=True)
            results.append(result)
    return results


def summary(results: list[SeedResult]) -> bool:
    """Coverage and the constants' intervals; whether every target so far is met."""
    covered = [v for r in results for v in r.covered]
    coverage = float(np.mean(covered)) if covered else float("nan")
    print(
        f"95% coverage after correction (leave-one-out): {coverage:.1%} of {len(covered)} "
        "trials (target 90-99% over >= 500 trials)"
    )
    within, fitted = sum(r.within for r in results), sum(r.fitted for r in results)
    share = within / max(fitted, 1)
    print(f"constants within their 95% intervals of the truth: {within} of {fitted} ({share:.0%})")
    ok = all(r.ok for r in results) and share >= 0.9
    return ok and 0.90 <= coverage <= 0.99 and len(covered) >= 500


def workflow_table(results: list[SeedResult], seeds: int, folder: Path, workers: int) -> bool:
    """Calibrate once on the other seeds, apply to this one (see the docstring)."""
    print()
    print("calibrated once on the other seeds' sessions (rig, then run --rig):")
    print("method seed   n  rmse_without  with_rig (ratio, <= 1.15)")
    with ProcessPoolExecutor(workers) as pool:
        once = list(
            pool.map(calibrated_once, results, [seeds] * len(results), [folder] * len(results))
        )
    ok = True
    for r, value in zip(results, once, strict=True):
        print(
            f"{r.method:6} {r.seed:4} {len(r.both):3}  {r.base:12.3f}  "
            f"{value:8.3f} ({value / r.base:.3f})"
        )
        ok &= value <= 1.15 * r.base
    print("pooled over the seeds (RMSE over every seed's common trials):")
    print(
        "method  rmse_without  rmse_with  with_loo (ratio)  with_rig (ratio)  without_loo (ratio)"
    )
    for method in dict.fromkeys(r.method for r in results):
        rs = [r for r in results if r.method == method]
        squares = sum(
            len(r.both) * v**2 for r, v in zip(results, once, strict=True) if r.method == method
        )
        rig = float(np.sqrt(squares / sum(len(r.both) for r in rs)))
        base, loo, loo0 = pooled(rs, "base"), pooled(rs, "loo_with"), pooled(rs, "loo_without")
        print(
            f"{method:6}  {base:12.3f}  {pooled(rs, 'with_raw'):9.3f}  "
            f"{loo:8.3f} ({loo / base:.3f})"
            f"  {rig:8.3f} ({rig / base:.3f})  {loo0:8.3f} ({loo0 / base:.3f})"
        )
    return ok


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
