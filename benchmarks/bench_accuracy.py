"""Accuracy against the Cramer-Rao bound: triangulation RMSE on simulated data with known noise.

    .venv/bin/python benchmarks/bench_accuracy.py [--samples 50000] [--sigma-px 0.25 0.5]

Two cameras of the thesis (f = 525 px, 640x480, poses known exactly) look at a point at a
given ray parallax (0.5 to 10 degrees). Each sample draws its own geometry: the point
anywhere in camera 1's image at 4-16 units, camera 2 at 0.5-2x that distance (so the depths
differ, where algebraic methods lose), turned toward the point give or take 10 degrees; and
adds N(0, sigma_px) to both pixel coordinates in both views. The bound of a sample is
``trace(F^-1)`` with the Fisher information ``F = sum_i J_i^T J_i / sigma^2`` of the
projections at the truth; a row reports sqrt(mean squared error) / sqrt(mean bound).
Estimators: the thesis' midpoint (eq. 7-8), the reprojection-optimal point (Gauss-Newton;
for two views it equals Lindstrom's niter2, see tests/analysis/test_solve.py), and OpenCV's
linear DLT (cv2.triangulatePoints).

Targets (issue 5): optimal within 2% of the bound at parallax >= 2 deg and within 6% at
0.5 deg, at the thesis' noise (0.25 px; larger sigmas are printed beside it). Exits 1 if a
target is missed.
"""

from __future__ import annotations

import argparse
import sys

import cv2
import numpy as np
import pandas as pd
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from twopose.solve.nview import projection_matrices, triangulate_points

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "accuracy.txt"
#: The noise the targets are stated for (the thesis' detector, issue 5).
TARGET_SIGMA_PX = 0.25

F64 = np.ndarray
K = np.array([525.0, 525.0, 320.0, 240.0])
DEPTH = 10.0
PARALLAX_DEG = (0.5, 1.0, 2.0, 5.0, 10.0)


def crb_rmse(point: F64, P: F64, sigma_px: float) -> float:
    """sqrt(trace) of the Cramer-Rao bound of a point seen by cameras P (N, 3, 4)."""
    X = np.append(point, 1.0)
    F = np.zeros((3, 3))
    for Pi in P:
        y = Pi @ X
        J = (Pi[:2, :3] - np.outer(y[:2] / y[2], Pi[2, :3])) / y[2]  # d(pixel)/d(point)
        F += J.T @ J / sigma_px**2
    return float(np.sqrt(np.trace(np.linalg.inv(F))))


def _unit(v: F64) -> F64:
    return np.asarray(v / np.linalg.norm(v, axis=-1, keepdims=True))


def geometry(parallax_deg: float, samples: int, rng: np.random.Generator) -> tuple[F64, F64]:
    """Truth points (S, 3) and camera pairs P (S, 2, 3, 4) at the given parallax."""
    pix = np.column_stack([rng.uniform(60, 580, samples), rng.uniform(60, 420, samples)])
    ray = _unit(np.column_stack([(pix - K[2:]) / K[:2], np.ones(samples)]))
    truth = ray * rng.uniform(4, 16, samples)[:, None] / ray[:, 2:]  # camera 1 at the origin
    back = -truth  # point -> camera 1
    axis = _unit(np.cross(back, rng.normal(size=(samples, 3))))
    p = np.radians(parallax_deg)
    # Rodrigues: turn (point -> camera 1) by the parallax about an axis across it.
    turned = back * np.cos(p) + np.cross(axis, back) * np.sin(p)
    centre2 = truth + turned * rng.uniform(0.5, 2.0, samples)[:, None]
    # Camera 2 looks at the point, give or take 10 degrees, with a random roll.
    z = _unit(
        truth
        - centre2
        + 0.18
        * np.linalg.norm(turned, axis=1)[:, None]
        * _unit(rng.normal(size=(samples, 3)))
        * rng.uniform(0, 1, samples)[:, None]
    )
    x = _unit(np.cross(rng.normal(size=(samples, 3)), z))
    R2 = np.stack([x, np.cross(z, x), z], axis=-1)  # columns: camera axes in the grid frame
    R = np.stack([np.broadcast_to(np.eye(3), R2.shape), R2], axis=1)
    t = np.stack([np.zeros_like(centre2), centre2], axis=1)
    return truth, projection_matrices(K, R, t)


def _project(truth: F64, P: F64) -> F64:
    y = np.einsum("snij,sj->sni", P, np.column_stack([truth, np.ones(len(truth))]))
    return np.asarray(y[..., :2] / y[..., 2:])


def trial(
    parallax_deg: float, samples: int, sigma_px: float, rng: np.random.Generator
) -> dict[str, float | str]:
    truth, P = geometry(parallax_deg, samples, rng)
    clean = _project(truth, P)
    inside = ((clean > 0) & (clean < [640, 480])).all(axis=(1, 2))
    truth, P, clean = truth[inside], P[inside], clean[inside]
    px = clean + sigma_px * rng.standard_normal(clean.shape)
    estimates = {
        "thesis (midpoint)": triangulate_points(px, P).point_grid,
        "optimal (Gauss-Newton)": triangulate_points(px, P, estimator="optimal").point_grid,
    }
    dlt = np.empty_like(truth)
    for i in range(len(truth)):
        Xh = cv2.triangulatePoints(P[i, 0], P[i, 1], px[i, 0, :, None], px[i, 1, :, None])
        dlt[i] = Xh[:3, 0] / Xh[3, 0]
    estimates["DLT (cv2)"] = dlt
    bound = np.array([crb_rmse(truth[i], P[i], sigma_px) for i in range(len(truth))])
    crb = float(np.sqrt(np.mean(bound**2)))
    row: dict[str, float | str] = {"parallax_deg": parallax_deg, "samples": len(truth), "crb": crb}
    for name, est in estimates.items():
        ok = np.isfinite(est).all(axis=1)
        rmse = float(np.sqrt(np.mean(np.sum((est[ok] - truth[ok]) ** 2, axis=1))))
        row[name] = rmse / float(np.sqrt(np.mean(bound[ok] ** 2)))
    return row


def main(argv: list[str]) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--samples", type=int, default=50_000)
    ap.add_argument("--sigma-px", type=float, nargs="+", default=[0.25, 0.5])
    ap.add_argument("--seed", type=int, default=0)
    args = ap.parse_args(argv)
    met = [
        _report(sigma_px, args.samples, np.random.default_rng(args.seed))
        for sigma_px in args.sigma_px
    ]
    return (
        0
        if all(
            ok
            for sigma_px, ok in zip(args.sigma_px, met, strict=True)
            if sigma_px <= TARGET_SIGMA_PX
        )
        else 1
    )


def _report(sigma_px: float, samples: int, rng: np.random.Generator) -> bool:
    """Print one noise level's table; whether its optimal estimator meets the targets."""
    table = pd.DataFrame([trial(p, samples, sigma_px, rng) for p in PARALLAX_DEG])
    print(
        f"RMSE / Cramer-Rao bound, {samples} samples a row, sigma = {sigma_px} px, "
        f"geometry drawn per sample (crb: RMS bound, units):"
    )
    print(table.to_string(index=False, float_format=lambda v: f"{v:.4f}"))
    opt = table.set_index("parallax_deg")["optimal (Gauss-Newton)"]
    ok = bool((opt[opt.index >= 2.0] <= 1.02).all() and opt.loc[0.5] <= 1.06)
    binding = (
        "" if sigma_px <= TARGET_SIGMA_PX else f" (targets stated for <= {TARGET_SIGMA_PX} px)"
    )
    print(
        "targets (optimal within 2% at >= 2 deg, 6% at 0.5 deg):",
        f"{'met' if ok else 'MISSED'}{binding}",
    )
    print()
    return ok


if __name__ == "__main__":
    raise SystemExit(run_recorded(lambda: main(sys.argv[1:]), FIGURE))
