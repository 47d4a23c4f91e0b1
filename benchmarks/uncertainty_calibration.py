"""Is the reported uncertainty honest? Coverage and NEES on >= 1000 simulated trials per method.

    python benchmarks/uncertainty_calibration.py [--trials 1000] [--workdir DIR] [--jobs 2]

Simulates sessions of the default (thesis) scene, in which the operator's placing error is
N(0, 0.1 in) on every typed component and is recorded as each pose's 1-sigma resolution, runs
the ordinary analysis over them, and reports per method: the share of trials whose truth
lies inside the reported 95% ellipsoid (target 93-97%) and the mean normalized error NEES
(target: its degrees of freedom, 3 for a point, +-10%; a ground point and a line's offset
have 2). Sessions are kept in --workdir, so a second run only re-analyses.
"""

from __future__ import annotations

import argparse
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

import numpy as np
import pandas as pd
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from analysis import run
from analysis.batch.outputs import replacing
from recorder.simulate.one_camera import simulate_session
from twopose.methods.specs import Method

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "uncertainty_calibration.txt"

METHODS = ("point", "line", "ground")
TRIALS_PER_SESSION = 100
FRAMES = 3


def _simulate(job: tuple[str, int, int, str]) -> str:
    method, seed, trials, out = job
    if not Path(out).exists():  # written under another name first: a kill leaves no half file
        with replacing(Path(out)) as partial:
            simulate_session(
                partial, method=Method(method), trials=trials, frames=FRAMES, seed=seed
            )
    return out


def calibration_table(trials: pd.DataFrame) -> pd.DataFrame:
    """Per method: trials, mean NEES and its degrees of freedom, 95% coverage."""
    ok = trials[(trials["status"] == "ok") & trials["nees"].notna()]
    rows = []
    for method, g in ok.groupby("method", sort=False):
        dof = float(g["nees_dof"].mean())
        nees = float(g["nees"].mean())
        coverage = float(g["within95"].mean())
        rows.append(
            {
                "method": method,
                "trials": len(g),
                "dof": dof,
                "mean_nees": nees,
                "nees_over_dof": nees / dof,
                "coverage95": coverage,
                "pass": bool(0.93 <= coverage <= 0.97 and abs(nees / dof - 1.0) <= 0.1),
            }
        )
    return pd.DataFrame(rows)


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--trials", type=int, default=1000, help="trials per method")
    ap.add_argument("--workdir", type=Path, default=Path("benchmarks/.calibration"))
    ap.add_argument("--jobs", type=int, default=2)
    args = ap.parse_args(argv)
    args.workdir.mkdir(parents=True, exist_ok=True)
    jobs = []
    for m, method in enumerate(METHODS):
        for s in range(int(np.ceil(args.trials / TRIALS_PER_SESSION))):
            n = min(TRIALS_PER_SESSION, args.trials - s * TRIALS_PER_SESSION)
            out = args.workdir / f"{method}_{n}_{s:03d}.mcap"
            jobs.append((method, 1000 * (m + 1) + s, n, str(out)))
    t0 = time.perf_counter()
    with ProcessPoolExecutor(args.jobs) as pool:
        files = list(pool.map(_simulate, jobs))
    t1 = time.perf_counter()
    result = run(files, jobs=args.jobs)
    t2 = time.perf_counter()
    table = calibration_table(result.trials)
    print(f"simulated in {t1 - t0:.0f} s, analysed in {t2 - t1:.0f} s")
    print(table.to_string(index=False, float_format=lambda v: f"{v:.3f}"))
    return 0 if bool(table["pass"].all()) else 1


if __name__ == "__main__":
    raise SystemExit(run_recorded(lambda: main(sys.argv[1:]), FIGURE))
