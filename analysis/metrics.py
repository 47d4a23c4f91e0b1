"""Metrics: estimates against ground truth, as tidy tables (one row per trial / session).

Vectors are ``x, y, z`` columns in the grid frame and the session's units.
"""

from __future__ import annotations

from statistics import NormalDist

import numpy as np
import pandas as pd
from numpy.typing import NDArray

from twopose.uncertainty import CHI2_3DOF_95, CHI2_95, nees

__all__ = [
    "NOTES_COLUMNS",
    "SUMMARY_COLUMNS",
    "TRIAL_COLUMNS",
    "UNCERTAINTY_COLUMNS",
    "WEIGHTED_COLUMNS",
    "line_errors",
    "summarize",
    "uncertainty_columns",
]

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
#: The operator's notes about the trial, joined with " | " (session-wide notes: the report).
NOTES_COLUMNS = ["notes"]
#: Line trials: the weighted/robust fit beside the thesis' (solve.triangulate_lines).
WEIGHTED_COLUMNS = [
    "x_weighted",
    "y_weighted",
    "z_weighted",
    "angle_err_weighted_deg",
    "dist_err_weighted",
]
#: Degeneracy margins (degrees) per method, and the warning when one is under its threshold.
MARGIN_COLUMNS = [
    "parallax_deg",
    "plane_angle_deg",
    "line_ground_angle_deg",
    "warning",
    "baseline",  # the longest distance between two typed camera centres of the trial
]
#: Point trials: the reprojection-optimal estimate beside the thesis' (x, y, z).
OPTIMAL_COLUMNS = ["x_optimal", "y_optimal", "z_optimal", "err_optimal"]
#: First-order uncertainty of (x, y, z) (analysis/uncertainty.py): 1-sigma per axis, the
#: covariances, 95% half-widths per axis, the 95% ellipsoid's longest semi-axis, the
#: normalized error ``nees`` over its ``nees_dof`` non-degenerate directions (when truth is
#: known; a ground point has 2, its height being exact) and whether the truth is inside the
#: 95% ellipsoid; then the input that dominates the variance, its share, and rejected frames.
UNCERTAINTY_COLUMNS = [
    "sigma_x",
    "sigma_y",
    "sigma_z",
    "cov_xy",
    "cov_xz",
    "cov_yz",
    "ci95_x",
    "ci95_y",
    "ci95_z",
    "semiaxis95",
    "nees",
    "nees_dof",
    "within95",
    "dominant_input",
    "dominant_share",
    "rejected_frames",
]
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


def uncertainty_columns(error: F64, cov: F64) -> dict[str, F64]:
    """The uncertainty columns computable from errors (T, 3) and covariances (T, 3, 3)."""
    sigma = np.sqrt(np.diagonal(cov, axis1=1, axis2=2))
    with np.errstate(invalid="ignore"):
        eig = np.full(len(cov), np.nan)
        finite = np.isfinite(cov).all(axis=(1, 2))
        if finite.any():
            eig[finite] = np.linalg.eigvalsh(cov[finite])[:, -1]
        score, dof = nees(error, cov)
        limit = np.array([CHI2_95.get(int(d), np.nan) for d in dof])
        within = np.where(np.isfinite(score), score <= limit, np.nan)
    half95 = NormalDist().inv_cdf(0.975)
    return {
        **{f"sigma_{a}": sigma[:, i] for i, a in enumerate("xyz")},
        "cov_xy": cov[:, 0, 1],
        "cov_xz": cov[:, 0, 2],
        "cov_yz": cov[:, 1, 2],
        **{f"ci95_{a}": half95 * sigma[:, i] for i, a in enumerate("xyz")},
        "semiaxis95": np.sqrt(CHI2_3DOF_95 * eig),
        "nees": score,
        "nees_dof": dof,
        "within95": within,
    }


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
        known = total[~np.isnan(total)]  # no truth: no error to summarize
        m = len(known)
        with np.errstate(over="ignore"):
            rmse = float(np.sqrt(np.mean(known**2))) if m else np.nan
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
                "rmse": rmse,
                "median_err": float(np.median(known)) if m else np.nan,
                "max_err": float(known.max()) if m else np.nan,
                "within_1": float(np.mean(known <= 1.0)) if m else np.nan,
            }
        )
    return pd.DataFrame(rows, columns=SUMMARY_COLUMNS)
