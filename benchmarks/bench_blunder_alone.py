"""A typo in a small session of an operator placing worse than typed, analysed alone (issue
54; a new user's F2, round 4): what the words say, which trials are flagged, and the clean
trials' regions.

    .venv/bin/python benchmarks/bench_blunder_alone.py [--sessions 40] [--placing 1.6]
        [--write-docs]

``bench_noise.py``'s sessions (the simulator's geometry, projected; 3 poses a trial) of 2
to 5 trials, the operator placing ``--placing`` times the typed 1/16 in, each session
analysed alone (no other session of the operator: its first session, or an operator named
once). In each, one pose of one trial (drawn) has its typed x 1 in off (either sign); the
same session without it is the clean one. Per method and size:

- ``agree``: the share of sessions whose words say "the data agree with the noise model"
  unqualified, clean and with the typo. On a small session's few dof sigma0's test misses
  an operator this much worse often (a power limit, docs/uncertainty.md); a typo must never
  make the words more reassuring than the clean session's: where flagging turned the test
  they say both numbers, never "agree" alone;
- ``typo flagged``, ``clean flagged``: the typo's trial flagged (by any test), the clean
  trials flagged;
- ``clean cover``: the unflagged clean trials' coverage of their truth by their 95% region;
- ``clean region``: the clean trials' largest semi-axis over the same trial's in the clean
  session (median, 90th percentile): a typo kept in the pool widens them.

Target (exit 1 if missed), per method over the sizes: ``agree`` with the typo at most the
clean sessions'.
"""

from __future__ import annotations

import argparse
import dataclasses
import sys
import time
from pathlib import Path

import numpy as np
import pandas as pd
from doc_figures import finished, run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from bench_noise import METHODS, SIZES, session  # type: ignore[import-not-found]  # noqa: E402

from twopose.methods.truth import reported  # noqa: E402
from twopose.solve.estimate import EstimateOptions  # noqa: E402
from twopose.solve.session import SessionEstimate, SessionTrials, estimate_session  # noqa: E402
from twopose.uncertainty.noise_words import describe  # noqa: E402
from twopose.uncertainty.propagate import uncertainty_columns  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "blunder_alone.txt"
AGREE = "the data agree with the noise model"
TYPO_IN = 1.0


def typo(trials: SessionTrials, seed: int) -> tuple[SessionTrials, int]:
    """The session with one drawn pose of one drawn trial typed 1 in off in x, and which trial."""
    rng = np.random.default_rng([seed, 2])
    i, j = int(rng.integers(len(trials))), int(rng.integers(len(trials.views[0])))
    off = np.array([TYPO_IN * rng.choice([-1.0, 1.0]), 0.0, 0.0])
    views = [list(row) for row in trials.views]
    views[i][j] = dataclasses.replace(views[i][j], t_grid=views[i][j].t_grid + off)
    return dataclasses.replace(trials, views=views), i


def _regions(e: SessionEstimate) -> tuple[np.ndarray, np.ndarray]:
    rep = reported(e)
    cols = uncertainty_columns(rep.error, rep.cov)
    return np.asarray(cols["within95"], dtype=bool), np.asarray(cols["semiaxis95"])


def rows(n: int, placing: float) -> pd.DataFrame:
    out = []
    for method in METHODS:
        for size in SIZES:
            for k in range(n):
                seed = 900_000 + 100_000 * METHODS.index(method) + 1000 * size + k
                clean = session(method, seed, size, placing)
                bad, which = typo(clean, seed)
                e0 = estimate_session(clean, EstimateOptions(), line_fits=False)
                e = estimate_session(bad, EstimateOptions(), line_fits=False)
                assert e.factor is not None
                assert e0.factor is not None
                assert e.tests is not None
                within, axis = _regions(e)
                _, axis0 = _regions(e0)
                ok = (e.estimates.status == "ok") & (e0.estimates.status == "ok")
                is_clean = ok & (np.arange(size) != which)
                out.append({
                    "method": str(method), "size": size,
                    "agree_clean": AGREE in describe(e0.factor),
                    "agree_typo": AGREE in describe(e.factor),
                    "typo_flagged": bool(e.tests.flagged[which]),
                    "clean": int(is_clean.sum()),
                    "clean_flagged": int((e.tests.flagged & is_clean).sum()),
                    "covered": list(within[is_clean & ~e.tests.flagged]),
                    "ratio": list((axis / axis0)[is_clean & ~e.tests.flagged]),
                })  # fmt: skip
    return pd.DataFrame(out)


def report(t: pd.DataFrame, placing: float) -> list[str]:
    print(f"one 1 in typo a session, operator placing {placing:g}x typed, each session alone")
    print(f"{'method':<8}{'size':>5}{'agree clean':>12}{'agree typo':>11}{'typo flagged':>13}"
          f"{'clean flagged':>14}{'clean cover':>12}{'clean region median':>20}"
          f"{'90th':>7}")  # fmt: skip
    missed = []
    for method, g in t.groupby("method", sort=False):
        for size, h in [*g.groupby("size"), ("all", g)]:
            ratio = np.concatenate(h["ratio"].to_list())
            covered = np.concatenate(h["covered"].to_list())
            print(f"{method:<8}{size!s:>5}{h['agree_clean'].mean():>12.0%}"
                  f"{h['agree_typo'].mean():>11.0%}{h['typo_flagged'].mean():>13.0%}"
                  f"{h['clean_flagged'].sum() / max(h['clean'].sum(), 1):>14.1%}"
                  f"{covered.mean():>12.1%}{np.median(ratio):>20.3f}"
                  f"{np.quantile(ratio, 0.9):>7.3f}")  # fmt: skip
        if g["agree_typo"].mean() > g["agree_clean"].mean():
            missed.append(f"{method}: a typo made 'agree' likelier than the clean sessions'")
    return missed


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--sessions", type=int, default=40)
    parser.add_argument("--placing", type=float, default=1.6)
    parser.add_argument("--write-docs", action="store_true")
    args = parser.parse_args()
    started = time.perf_counter()
    print(f"{args.sessions} sessions a cell, 3 poses a trial\n")
    missed = report(rows(args.sessions, args.placing), args.placing)
    return finished(started, missed)


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
