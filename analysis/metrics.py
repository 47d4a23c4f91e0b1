"""Metrics: estimates against ground truth, as tidy tables (one row per trial / session).

Vectors are ``x, y, z`` columns in the grid frame and the session's units.
"""

from __future__ import annotations

import numpy as np
import pandas as pd
from numpy.typing import NDArray

__all__ = ["SUMMARY_COLUMNS", "TRIAL_COLUMNS", "line_errors", "summarize"]

F64 = NDArray[np.float64]

TRIAL_COLUMNS = [
    "session",
    "trial",
    "method",
    "units",
    "status",
    "reason",
    "n_views",
    "conditioning",
    "x",
    "y",
    "z",
    "gt_x",
    "gt_y",
    "gt_z",
    "err_x",
    "err_y",
    "err_z",
    "err",
]
LINE_COLUMNS = ["dir_x", "dir_y", "dir_z", "angle_err_deg", "dist_err"]
#: Degeneracy margins (degrees) per method, and the warning when one is under its threshold.
MARGIN_COLUMNS = ["parallax_deg", "plane_angle_deg", "line_ground_angle_deg", "warning"]
#: Point trials: the reprojection-optimal estimate beside the thesis' (x, y, z).
OPTIMAL_COLUMNS = ["x_optimal", "y_optimal", "z_optimal", "err_optimal"]
SUMMARY_COLUMNS = [
    "session",
    "method",
    "units",
    "n_trials",
    "n_ok",
    "bias_x",
    "bias_y",
    "bias_z",
    "std_x",
    "std_y",
    "std_z",
    "rmse",
    "median_err",
    "max_err",
    "within_1",
]


def line_errors(
    point_grid: F64, direction_grid: F64, gt_a: F64, gt_b: F64
) -> tuple[F64, F64, F64, F64]:
    """Compare estimated lines with ground-truth lines.

    Parameters
    ----------
    point_grid, direction_grid : (T, 3)
        A point on each estimated line and its unit direction.
    gt_a, gt_b : (T, 3)
        Two points on each true line.

    Returns
    -------
    nearest : (T, 3)
        The estimated line's point nearest the true segment's midpoint.
    midpoint : (T, 3)
        The true segment's midpoint.
    angle_err_deg : (T,)
        Angle between the lines, in [0, 90] degrees (lines have no arrow).
    dist_err : (T,)
        Distance from the true midpoint to the estimated line.
    """
    mid = 0.5 * (gt_a + gt_b)
    s = np.einsum("ti,ti->t", mid - point_grid, direction_grid)
    nearest = point_grid + s[:, None] * direction_grid
    gt_dir = (gt_b - gt_a) / np.linalg.norm(gt_b - gt_a, axis=1, keepdims=True)
    cos = np.clip(np.abs(np.einsum("ti,ti->t", gt_dir, direction_grid)), 0.0, 1.0)
    angle = np.degrees(np.arccos(cos))
    dist = np.linalg.norm(nearest - mid, axis=1)
    return nearest, mid, angle, dist


def summarize(trials: pd.DataFrame) -> pd.DataFrame:
    """One row per session and method: bias, spread and error statistics over ok trials.

    ``within_1`` is the share of ok trials whose error is within 1 session unit (the
    thesis' "< 1 inch").
    """
    rows = []
    for (session, method), g in trials.groupby(["session", "method"], sort=True):
        ok = g[g["status"] == "ok"]
        err = ok[["err_x", "err_y", "err_z"]].to_numpy(dtype=np.float64)
        total = ok["err"].to_numpy(dtype=np.float64)
        n = len(ok)
        rows.append(
            {
                "session": session,
                "method": method,
                "units": g["units"].iloc[0],
                "n_trials": len(g),
                "n_ok": n,
                **{f"bias_{a}": (err[:, i].mean() if n else np.nan) for i, a in enumerate("xyz")},
                **{
                    f"std_{a}": (err[:, i].std(ddof=1) if n > 1 else np.nan)
                    for i, a in enumerate("xyz")
                },
                "rmse": float(np.sqrt(np.mean(total**2))) if n else np.nan,
                "median_err": float(np.median(total)) if n else np.nan,
                "max_err": float(total.max()) if n else np.nan,
                "within_1": float(np.mean(total <= 1.0)) if n else np.nan,
            }
        )
    return pd.DataFrame(rows, columns=SUMMARY_COLUMNS)
