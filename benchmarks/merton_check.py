"""Reconstruct Merton College I (three real calibrated views) and compare with its reference.

    .venv/bin/python benchmarks/merton_check.py [--data data/merton1]

Points: N-view triangulation of the matched corners, thesis least squares and reprojection
optimal (Gauss-Newton), against ``p3d`` (itself a reprojection-optimal reconstruction).
Lines: planes back-projected from the matched segments, the rank-2 null space (``thesis``),
the weighted/robust fit and the reprojection-optimal line, against ``l3d``: direction
error, the distance of the measured segment endpoints to the reprojected line (median and
RMS; the optimal line minimises its sum of squares), and LIMAP's length-recall (the share
of l3d's segments' length within 0.1%, 0.5% and 1% of the scene's size of our line). Exits
1 if a target is missed.
"""

from __future__ import annotations

import argparse
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from twopose.solve.nview import NViewLines, segment_lines, triangulate_lines, triangulate_points
from twopose.solve.optimal_lines import OptimalLines, optimal_lines

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "merton_check.md"
DEFAULT = Path(__file__).resolve().parents[1] / "data" / "merton1"


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


#: The line estimators compared, and their figures' prefixes.
LINE_ESTIMATORS = ("thesis", "weighted", "optimal")
LINE_PREFIX = {"thesis": "line", "weighted": "weighted", "optimal": "optimal"}
#: LIMAP's thresholds as shares of the scene's size (Liu et al., CVPR 2023, Table 1).
LIMAP_THRESHOLDS = (0.001, 0.005, 0.01)


def length_within(
    a: np.ndarray, b: np.ndarray, point: np.ndarray, direction: np.ndarray, tau: float
) -> float:
    """The share of the reference segments' (a-b) total length that lies within ``tau`` of
    the estimated lines (point, unit direction): LIMAP's length-recall, per line pair.

    Along a segment ``a + s (b - a)``, the squared distance to the line is a quadratic in
    ``s``; the part of [0, 1] where it is at most ``tau^2`` is found in closed form.
    """

    def across(v: np.ndarray) -> np.ndarray:
        return np.asarray(v - (v * direction).sum(1, keepdims=True) * direction)

    p, q = across(a - point), across(b - a)  # distance vector p + s q
    qq, pq, pp = (q * q).sum(1), (p * q).sum(1), (p * p).sum(1) - tau**2
    disc = pq**2 - qq * pp
    root = np.sqrt(np.clip(disc, 0.0, None))
    with np.errstate(divide="ignore", invalid="ignore"):
        lo = np.where(qq > 0, (-pq - root) / qq, np.where(pp <= 0, 0.0, 1.0))
        hi = np.where(qq > 0, (-pq + root) / qq, np.where(pp <= 0, 1.0, 0.0))
    inside = np.where(disc >= 0, np.clip(hi, 0, 1) - np.clip(lo, 0, 1), 0.0)
    inside = np.where(np.isfinite(inside), np.clip(inside, 0.0, 1.0), 0.0)
    length = np.linalg.norm(b - a, axis=1)
    return float((inside * length).sum() / length.sum())


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
    P = np.broadcast_to(m.P, (n_lines, 3, 3, 4))
    for estimator in LINE_ESTIMATORS:
        if estimator == "optimal":
            ls: NViewLines | OptimalLines = optimal_lines(m.segments, P)
        else:
            ls = triangulate_lines(segment_lines(m.segments), P, estimator=estimator)
        prefix = LINE_PREFIX[estimator]
        cosine = np.clip(np.abs((ls.direction_grid * ref).sum(1)), 0.0, 1.0)
        figures[f"{prefix}_angle_median_deg"] = float(np.median(np.degrees(np.arccos(cosine))))
        res = endpoint_residuals(m, ls.point_grid, ls.point_grid + ls.direction_grid)
        figures[f"{prefix}_residual_median_px"] = float(np.median(res))
        figures[f"{prefix}_residual_rms_px"] = float(np.sqrt(np.mean(res**2)))
        for tau in LIMAP_THRESHOLDS:
            share = length_within(
                m.l3d[:, :3], m.l3d[:, 3:], ls.point_grid, ls.direction_grid, tau * scene
            )
            figures[f"{prefix}_within_{tau:g}"] = share
    res = endpoint_residuals(m, m.l3d[:, :3], m.l3d[:, 3:])
    figures["l3d_residual_median_px"] = float(np.median(res))
    figures["l3d_residual_rms_px"] = float(np.sqrt(np.mean(res**2)))
    return figures


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--data", type=Path, default=DEFAULT)
    return _report(parser.parse_args())


def _report(args: argparse.Namespace) -> int:
    f = check(load(args.data))
    print(
        f"points (717, scene size {f['scene']:.2f}): thesis least squares max error "
        f"{f['thesis_max_rel']:.1e} of the scene (median {f['thesis_median_rel']:.1e}); "
        f"optimal {f['optimal_max_rel']:.1e} (median {f['optimal_median_rel']:.1e}; "
        "target <= 1e-6)"
    )
    taus = ", ".join(f"{t * f['scene']:.3f}" for t in LIMAP_THRESHOLDS)
    print(
        "lines (295): median direction error vs l3d, endpoint distance to the reprojected "
        "line (median, RMS), and the share of l3d's length within 0.1%, 0.5%, 1% of the "
        f"scene ({taus} units) of the line:"
    )
    print()
    print(
        "| estimator | angle (deg) | residual median (px) | residual RMS (px) | 0.1% | 0.5% | 1% |"
    )
    print("| --- | ---: | ---: | ---: | ---: | ---: | ---: |")
    for estimator in LINE_ESTIMATORS:
        x = LINE_PREFIX[estimator]
        shares = " | ".join(f"{f[f'{x}_within_{t:g}']:.1%}" for t in LIMAP_THRESHOLDS)
        angle, median = f[f"{x}_angle_median_deg"], f[f"{x}_residual_median_px"]
        rms = f[f"{x}_residual_rms_px"]
        print(f"| `{estimator}` | {angle:.2f} | {median:.3f} | {rms:.3f} | {shares} |")
    print(
        f"| `l3d` (reference) | 0 | {f['l3d_residual_median_px']:.3f} "
        f"| {f['l3d_residual_rms_px']:.3f} | 100% | 100% | 100% |"
    )
    print()
    print(
        "targets: thesis angle < 3.5 deg; every estimator's median residual <= l3d's; "
        "optimal RMS <= l3d's and <= thesis'"
    )
    ok = (
        f["optimal_max_rel"] <= 1e-6
        and f["line_angle_median_deg"] < 3.5
        and all(
            f[f"{x}_residual_median_px"] <= f["l3d_residual_median_px"]
            for x in LINE_PREFIX.values()
        )
        and f["optimal_residual_rms_px"] <= min(f["l3d_residual_rms_px"], f["line_residual_rms_px"])
    )
    return 0 if ok else 1


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
