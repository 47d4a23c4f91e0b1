"""Reconstruct Merton College I (three real calibrated views) and compare with its reference.

    .venv/bin/python benchmarks/merton_check.py [--data ../shared/data/merton1]

Points: N-view triangulation of the matched corners, thesis least squares and reprojection
optimal (Gauss-Newton), against ``p3d`` (itself a reprojection-optimal reconstruction).
Lines: planes back-projected from the matched segments, the rank-2 null space, against
``l3d``: direction error and the median distance of the measured segment endpoints to the
reprojected line, ours and l3d's. Exits 1 if a target is missed.
"""

from __future__ import annotations

import argparse
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from twopose.solve import segment_lines, triangulate_lines, triangulate_points

DEFAULT = Path(__file__).resolve().parents[1].parent / "shared" / "data" / "merton1"


@dataclass(frozen=True)
class Merton:
    P: np.ndarray  # (3, 3, 4)
    corner_px: np.ndarray  # (717, 3, 2), NaN where a view does not see the point
    segments: np.ndarray  # (295, 3, 4)
    p3d: np.ndarray
    l3d: np.ndarray


def load(folder: Path) -> Merton:
    P = np.stack([np.loadtxt(folder / f"00{i}.P") for i in (1, 2, 3)])
    corners = [np.loadtxt(folder / f"00{i}.corners") for i in (1, 2, 3)]
    lines = [np.loadtxt(folder / f"00{i}.lines") for i in (1, 2, 3)]

    def table(name: str) -> list[list[int | None]]:
        return [
            [None if v == "*" else int(v) for v in row.split()]
            for row in (folder / name).read_text().splitlines()
            if row.strip()
        ]

    px = np.array(
        [
            [corners[v][i] if i is not None else (np.nan, np.nan) for v, i in enumerate(row)]
            for row in table("nview-corners")
        ]
    )
    segs = np.array([[lines[v][i] for v, i in enumerate(row)] for row in table("nview-lines")])
    return Merton(P, px, segs, np.loadtxt(folder / "p3d"), np.loadtxt(folder / "l3d"))


def endpoint_residuals(m: Merton, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Distances (px) of every measured segment endpoint to the 3-D line a-b reprojected."""
    out = []
    for v in range(3):
        ha = np.c_[a, np.ones(len(a))] @ m.P[v].T
        hb = np.c_[b, np.ones(len(b))] @ m.P[v].T
        line = np.cross(ha, hb)
        line /= np.linalg.norm(line[:, :2], axis=1, keepdims=True)
        for end in (m.segments[:, v, :2], m.segments[:, v, 2:]):
            out.append(np.abs((np.c_[end, np.ones(len(end))] * line).sum(1)))
    return np.concatenate(out)


def check(m: Merton) -> dict[str, float]:
    n_pts, n_lines = len(m.p3d), len(m.l3d)
    scene = float(np.ptp(m.p3d, axis=0).max())
    figures: dict[str, float] = {"scene": scene}
    for estimator in ("thesis", "optimal"):
        sol = triangulate_points(
            m.corner_px, np.broadcast_to(m.P, (n_pts, 3, 3, 4)), estimator=estimator
        )
        err = np.linalg.norm(sol.point_grid - m.p3d, axis=1)
        figures[f"{estimator}_max_rel"] = float(err.max() / scene)
        figures[f"{estimator}_median_rel"] = float(np.median(err) / scene)
    ref = m.l3d[:, 3:] - m.l3d[:, :3]
    ref /= np.linalg.norm(ref, axis=1, keepdims=True)
    for estimator, prefix in (("thesis", "line"), ("weighted", "weighted")):
        ls = triangulate_lines(
            segment_lines(m.segments),
            np.broadcast_to(m.P, (n_lines, 3, 3, 4)),
            estimator=estimator,
        )
        cosine = np.clip(np.abs((ls.direction_grid * ref).sum(1)), 0.0, 1.0)
        figures[f"{prefix}_angle_median_deg"] = float(np.median(np.degrees(np.arccos(cosine))))
        figures[f"{prefix}_residual_median_px"] = float(
            np.median(endpoint_residuals(m, ls.point_grid, ls.point_grid + ls.direction_grid))
        )
    figures["l3d_residual_median_px"] = float(
        np.median(endpoint_residuals(m, m.l3d[:, :3], m.l3d[:, 3:]))
    )
    return figures


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, default=DEFAULT)
    args = parser.parse_args()
    f = check(load(args.data))
    print(
        f"points (717, scene size {f['scene']:.2f}): thesis least squares max error "
        f"{f['thesis_max_rel']:.1e} of the scene (median {f['thesis_median_rel']:.1e}); "
        f"optimal {f['optimal_max_rel']:.1e} (median {f['optimal_median_rel']:.1e}; "
        "target <= 1e-6)"
    )
    print(
        f"lines (295): median direction error {f['line_angle_median_deg']:.2f} deg vs l3d "
        f"(target < 3.5); median endpoint residual {f['line_residual_median_px']:.3f} px, "
        f"l3d's {f['l3d_residual_median_px']:.3f} px (target: ours <= l3d's); weighted fit "
        f"{f['weighted_angle_median_deg']:.2f} deg, {f['weighted_residual_median_px']:.3f} px"
    )
    ok = (
        f["optimal_max_rel"] <= 1e-6
        and f["line_angle_median_deg"] < 3.5
        and f["line_residual_median_px"] <= f["l3d_residual_median_px"]
    )
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
