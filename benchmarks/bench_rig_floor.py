"""How far a session corrected by the true constants is from the same seed simulated
without them: the floor of the rig benchmarks' "<= 1.05x the same sessions without
constants" comparison.

    .venv/bin/python benchmarks/bench_rig_floor.py [--seeds 20] [--methods point ground]

Per seed: ``bench_rig.py``'s pair of measurement sessions (15 trials, the thesis' geometry;
with the constants of ``bench_rig.py`` and without), the one with constants corrected by the
true constants (``run --rig``), both judged on the trials both use. No calibration is
involved: whatever ratio a seed shows, no estimate of the constants can be expected to do
better. Beside the realised ratio, the ratio the solver itself predicts (the RMS of its
propagated 1-sigma over the same trials), and per method the RMSE pooled over every seed's
trials with a 95% interval from resampling the seeds. Prints one line per seed and method,
then the summary; no target (it measures what the board and target-trial benchmarks'
targets can ask).
"""

from __future__ import annotations

import argparse
import sys
import tempfile
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pandas as pd
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))
sys.path.insert(0, str(REPO / "benchmarks"))
sys.path.insert(0, str(REPO / "sessions"))

from bench_rig import RIG, simulate_pair  # type: ignore[import-not-found]  # noqa: E402 - on sys.path at run time

from analysis.batch.runner import run  # noqa: E402
from analysis.results import AnalysisOptions  # noqa: E402
from analysis.session.metrics import used_trials  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "rig_floor.txt"


@dataclass(frozen=True)
class Floor:
    """One seed and method: squared errors and predicted variances over the common trials."""

    method: str
    seed: int
    err2_without: np.ndarray  # (n,) squared error, session units^2
    err2_true: np.ndarray
    var_without: np.ndarray  # (n,) trace of the propagated covariance
    var_true: np.ndarray

    @property
    def ratio(self) -> float:
        return float(np.sqrt(self.err2_true.mean() / self.err2_without.mean()))

    @property
    def predicted(self) -> float:
        return float(np.sqrt(self.var_true.mean() / self.var_without.mean()))


def one_seed(method: str, seed: int) -> Floor:
    with tempfile.TemporaryDirectory(prefix="twopose-rig-floor-") as tmp:
        paths = simulate_pair(method, seed, Path(tmp))
        without = run([paths["without"]], None).trials
        true = run([paths["with"]], None, options=AnalysisOptions(rig=RIG)).trials
    both = set(used_trials(without)["trial"]) & set(used_trials(true)["trial"])
    without, true = (t[t["trial"].isin(both)].sort_values("trial") for t in (without, true))
    return Floor(
        method, seed, _column(without, "err") ** 2, _column(true, "err") ** 2,
        _variance(without), _variance(true),
    )  # fmt: skip


def _column(trials: pd.DataFrame, column: str) -> np.ndarray:
    return np.asarray(trials[column].to_numpy(dtype=np.float64))


def _variance(trials: pd.DataFrame) -> np.ndarray:
    """The trace of each trial's propagated covariance."""
    return np.sum([_column(trials, f"sigma_{axis}") ** 2 for axis in "xyz"], axis=0)


def pooled(floors: list[Floor], rng: np.random.Generator, resamples: int = 2000) -> str:
    """The ratio of the RMSEs pooled over every seed's trials, with a 95% interval from
    resampling the seeds (a seed's trials stay together)."""

    def ratio(chosen: list[Floor]) -> float:
        true = np.concatenate([f.err2_true for f in chosen]).mean()
        return float(np.sqrt(true / np.concatenate([f.err2_without for f in chosen]).mean()))

    drawn = [
        ratio([floors[i] for i in rng.integers(0, len(floors), len(floors))])
        for _ in range(resamples)
    ]
    lo, hi = np.percentile(drawn, [2.5, 97.5])
    n = sum(len(f.err2_true) for f in floors)
    return (
        f"pooled over {len(floors)} seeds ({n} trials): {ratio(floors):.3f} "
        f"(95%: {lo:.3f}-{hi:.3f})"
    )


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--seeds", type=int, default=20)
    ap.add_argument("--methods", nargs="+", default=["point", "ground"])
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    jobs = [(m, s) for m in args.methods for s in range(args.seeds)]
    print("method seed   n  ratio, true rig / without  predicted by the solver")
    floors: list[Floor] = []
    with ProcessPoolExecutor(args.workers) as pool:
        for floor in pool.map(one_seed, *zip(*jobs, strict=True)):
            floors.append(floor)
            print(
                f"{floor.method:6} {floor.seed:4} {len(floor.err2_true):3}  "
                f"{floor.ratio:25.3f}  {floor.predicted:23.3f}",
                flush=True,
            )
    rng = np.random.default_rng(0)
    for method in args.methods:
        mine = [f for f in floors if f.method == method]
        ratios = np.array([f.ratio for f in mine])
        predicted = np.array([f.predicted for f in mine])
        print(
            f"{method}: per seed {ratios.min():.3f}-{ratios.max():.3f}, over 1.05x on "
            f"{int((ratios > 1.05).sum())} of {len(mine)} (predicted {predicted.min():.3f}-"
            f"{predicted.max():.3f}); {pooled(mine, rng)}"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
