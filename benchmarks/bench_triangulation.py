"""Batched two-view point triangulation against OpenCV, on the same 100,000 points.

    .venv/bin/python benchmarks/bench_triangulation.py

Targets (issue 5): at least 4x faster per point than ``cv2.triangulatePoints``; the optimal
estimator (Lindstrom's niter2) at no more than 2x the cost of the midpoint. Timings are the
best of 7 runs each, in one process. Exits 1 if a target is missed.
"""

from __future__ import annotations

import time
from collections.abc import Callable

import cv2
import numpy as np
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from twopose.camera.model import rotation_from_angles_deg
from twopose.solve.nview import projection_matrices
from twopose.solve.two_view import triangulate_two_views

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "triangulation.txt"

N_POINTS = 100_000


def best_of(fn: Callable[[], object], runs: int = 7) -> float:
    fn()
    best = float("inf")
    for _ in range(runs):
        start = time.perf_counter()
        fn()
        best = min(best, time.perf_counter() - start)
    return best


def main() -> int:
    rng = np.random.default_rng(0)
    K = np.array([525.0, 525.0, 320.0, 240.0])
    P1 = projection_matrices(K, np.eye(3), np.zeros(3))
    P2 = projection_matrices(
        K, rotation_from_angles_deg([2.0, -5.0, 1.0]), np.array([1.5, 0.1, -0.5])
    )
    X = np.c_[rng.uniform([-2, -1, 8], [2, 3, 14], (N_POINTS, 3)), np.ones(N_POINTS)]
    px = [(X @ P.T)[:, :2] / (X @ P.T)[:, 2:] + rng.normal(0, 0.5, (N_POINTS, 2)) for P in (P1, P2)]
    t_cv = best_of(lambda: cv2.triangulatePoints(P1, P2, px[0].T.copy(), px[1].T.copy()))
    t_mid = best_of(lambda: triangulate_two_views(px[0], px[1], P1, P2))
    t_opt = best_of(lambda: triangulate_two_views(px[0], px[1], P1, P2, estimator="optimal"))
    speedup, ratio = t_cv / t_mid, t_opt / t_mid
    print(
        f"{N_POINTS} points: cv2.triangulatePoints {t_cv * 1e3:.1f} ms, "
        f"midpoint {t_mid * 1e3:.1f} ms "
        f"({speedup:.1f}x faster, target >= 4), optimal {t_opt * 1e3:.1f} ms "
        f"({ratio:.2f}x the midpoint, target <= 2)"
    )
    return 0 if speedup >= 4 and ratio <= 2 else 1


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
