"""Time against the number of views: one session trial with N poses through the whole
analysis, and one ``solve`` request with N views (the solvers and the uncertainty
propagation are batched: no Python loop over views or pairs of views).

    python benchmarks/bench_scaling.py [--poses 2 8 32 64 100] [--views 2 200 2000]
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from twopose.methods.specs import Method

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from analysis.session.pipeline import analyse_session  # noqa: E402
from analysis.tools.solve_request import solve_request  # noqa: E402
from recorder.simulate.one_camera import simulate_session  # noqa: E402
from twopose.sim.scene import Scene  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "scaling.txt"


def session_seconds(folder: Path, poses: int) -> float:
    path = folder / f"p{poses}.mcap"
    scene = Scene()  # many poses only fit the default ranges closer together
    scene = dataclasses.replace(scene, poses=dataclasses.replace(scene.poses, min_baseline=0.0))
    simulate_session(
        path, method=Method.GROUND, trials=2, frames=2, seed=1, poses=poses, scene=scene
    )
    started = time.perf_counter()
    trials = analyse_session(path).trials
    seconds = time.perf_counter() - started
    assert (trials["n_views"] == poses).all(), trials[["status", "reason", "n_views"]]
    return seconds


def solve_seconds(views: int) -> float:
    rng = np.random.default_rng(0)
    truth = np.array([0.5, 1.5, 11.0])
    request: dict[str, list[dict[str, object]]] = {"views": []}
    for _ in range(views):
        t = rng.uniform(-3, 3, 3) * [1, 0, 1]
        p = truth - t
        request["views"].append(
            {
                "K": [525, 525, 320, 240],
                "pose": {"t": t.tolist(), "r_deg": [0, 0, 0]},
                "px": [320 + 525 * p[0] / p[2], 240 + 525 * p[1] / p[2]],
            }
        )
    started = time.perf_counter()
    solve_request(Method.POINT, json.loads(json.dumps(request)))
    return time.perf_counter() - started


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    # 100: the most poses a scene (and a plan) may have per trial.
    parser.add_argument("--poses", type=int, nargs="+", default=[2, 8, 32, 64, 100])
    parser.add_argument("--views", type=int, nargs="+", default=[2, 200, 2000])
    args = parser.parse_args()
    print("python benchmarks/bench_scaling.py " + " ".join(sys.argv[1:]))
    with tempfile.TemporaryDirectory() as tmp:
        base = None
        for n in args.poses:
            s = session_seconds(Path(tmp), n)
            base = base or s / n
            print(f"analysis, 2 trials x {n:4d} poses: {s:7.2f} s  ({s / n / base:5.2f}x per pose)")
    base = None
    for n in args.views:
        s = solve_seconds(n)
        base = base or s / n
        print(f"solve, {n:5d} views: {s:7.3f} s  ({s / n / base:6.2f}x per view)")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
