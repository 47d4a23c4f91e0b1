"""Every output table's columns, declared once, in the order the files write them.

``docs/analysis.md`` documents each column (``tests/analysis/test_columns.py`` checks that
every one declared here is); the stages that fill a table import its list from here, and
give each column its dtype (:data:`DTYPES`, :func:`typed`: text never NaN, flags boolean),
as :func:`analysis.run_tables.read_table` reads the CSV back. What
``trials.csv``'s columns are each one declaration of :mod:`analysis.trial_columns` (name,
label, unit, domain, dtype and what fills it); what depends on the method (its extra
columns, its degeneracy margins) its spec names (:mod:`twopose.methods`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from analysis.trial_columns import TRIAL_TABLE, group

if TYPE_CHECKING:
    import pandas as pd

__all__ = [
    "AVERAGING_COLUMNS",
    "DTYPES",
    "ERROR_COLUMNS",
    "FRAME_COLUMNS",
    "IDENTITY_COLUMNS",
    "LINE_COLUMNS",
    "MARGIN_COLUMNS",
    "NOISE_COLUMNS",
    "NOTES_COLUMNS",
    "OPTIMAL_COLUMNS",
    "RIG_COLUMNS",
    "RIG_TABLE_COLUMNS",
    "RUN_TABLES",
    "SUMMARY_COLUMNS",
    "SUMMARY_COUNT_ORDER",
    "SUMMARY_DOMAINS",
    "TABLE_DOMAINS",
    "TRIAL_COLUMNS",
    "TRIAL_TABLE_COLUMNS",
    "UNCERTAINTY_COLUMNS",
    "VIEW_COLUMNS",
    "WEIGHTED_COLUMNS",
    "typed",
]

#: What a trial is besides its session's path and its number (:mod:`twopose.format.identity`):
#: its session's label (the shortest tail of its path no other input shares), the session's
#: id, the part (file) that recorded it, and its branch ("" on a session that never forked;
#: A, B, ... for the continuations of a part continued twice).
IDENTITY_COLUMNS = group("identity")
#: trials.csv: one row per trial; every trial's columns.
TRIAL_COLUMNS = [c.name for c in TRIAL_TABLE if c.group in ("trial", "identity")]
#: Line trials: the line's direction and its angle and distance errors.
LINE_COLUMNS = group("line")
#: The operator's notes about the trial, joined with " | " (session-wide notes: the report).
NOTES_COLUMNS = group("notes")
#: Line trials: the weighted/robust fit beside the thesis' (solve.triangulate_lines), and
#: the reprojection-optimal line's errors (twopose.optimal_lines; its point is ``x_optimal``...).
WEIGHTED_COLUMNS = group("line fits")
#: Degeneracy margins (degrees; each method's named by its spec), the warning when one is
#: under its threshold, and the trial's baseline (the longest distance between two typed
#: camera centres).
MARGIN_COLUMNS = group("margins")
#: Point trials: the reprojection-optimal estimate beside the thesis' (x, y, z); line
#: trials: the optimal line's point nearest the true midpoint and its distance from it.
OPTIMAL_COLUMNS = group("optimal")
#: First-order uncertainty of (x, y, z) (:mod:`twopose.uncertainty`), then the input that
#: dominates the variance, its share, and the frames rejected as outliers.
UNCERTAINTY_COLUMNS = group("uncertainty")
#: The noise model each trial's region assumed (:mod:`twopose.noise`): its placing sigma and
#: where it came from, its misclosure's chi-square and dof, and the widening applied.
NOISE_COLUMNS = group("noise")
#: trials.csv's columns from ``--rig-calibration loo`` (the last five: line trials only).
RIG_COLUMNS = group("rig")
#: ``trials.csv``, every session and method concatenated (a column a method lacks is empty):
#: :data:`analysis.trial_columns.TRIAL_TABLE`, one declaration per column.
TRIAL_TABLE_COLUMNS = [c.name for c in TRIAL_TABLE]

# The other tables.
#: ``summary.csv``: one row per session and method.
SUMMARY_COLUMNS = [
    "session",
    "label",
    "session_id",
    "branch",  # the branch the session's strand ends on
    "trials_key",  # which trials the row is over (their parts and numbers, hashed)
    "method",
    "units",
    "n_trials",
    "n_ok",
    "n_warned",  # ok trials with a near-degeneracy warning (left out unless --include-warned)
    "n_used",  # the trials the statistics below are over
    "bias_x",
    "bias_y",
    "bias_z",
    "bias_x_ci95",  # half-width of the 95% t-interval of each bias component
    "bias_y_ci95",
    "bias_z_ci95",
    "std_x",
    "std_y",
    "std_z",
    "rmse",
    "rmse_ci95_low",  # seeded bootstrap (2000 resamples) 95% interval of the RMSE
    "rmse_ci95_high",
    "median_err",
    "max_err",
    "within_1",
    "coverage95",  # share of used trials whose truth is inside their 95% ellipsoid
    "rmse_all_ok",  # the same over every ok trial, warned ones included
    "median_err_all_ok",
    "max_err_all_ok",
    # the noise model its regions assumed (twopose.noise; docs/analysis.md)
    "placing_sigma",  # the placing sigma (session units): measured, or the typed mean
    "placing_source",  # typed, or measured by which board session; the multiplier taken
    "placing_scale",  # the placing sigma taken over the one assumed (sqrt(lambda))
    "placing_dof",  # the degrees of freedom it rests on (empty: taken as exact)
    "rig_file",  # the rig file the session used (empty: none), as found or given
    "rig_sha256",  # its content's SHA-256 (empty: none): what check compares
    "sigma0",  # the unflagged trials' sigma0 under the typed model (1: the model holds)
    "sigma0_dof",  # its degrees of freedom (0: no trial with redundancy)
    "sigma0_p",  # its chi-square test's upper tail probability
    "noise_contradicted",  # sigma0's test rejects the typed model (sigma0_p < 5%)
    "noise_widening",  # the largest covariance multiplier applied (1: unchanged)
    "n_flagged",  # trials whose poses disagree: kept out of the pool, widened
]
#: What each number of ``summary.csv`` can be: ``count`` a whole number >= 0, ``length``
#: a finite length >= 0 (session units), ``signed`` any finite number, ``share`` 0 to 1.
#: Empty is "not measured"; anything else outside its domain no run writes, so ``check``
#: and ``compare`` refuse it (:func:`analysis.outputs.check_results_table`).
_LENGTHS = (
    "bias_x_ci95", "bias_y_ci95", "bias_z_ci95", "std_x", "std_y", "std_z", "rmse",
    "rmse_ci95_low", "rmse_ci95_high", "median_err", "max_err", "rmse_all_ok",
    "median_err_all_ok", "max_err_all_ok", "placing_sigma", "sigma0", "noise_widening",
    "placing_scale", "placing_dof",
)  # fmt: skip
SUMMARY_DOMAINS: dict[str, str] = {
    **dict.fromkeys(("n_trials", "n_ok", "n_warned", "n_used"), "count"),
    **dict.fromkeys(("bias_x", "bias_y", "bias_z"), "signed"),
    **dict.fromkeys(_LENGTHS, "length"),
    **dict.fromkeys(("within_1", "coverage95", "sigma0_p"), "share"),
    "n_flagged": "count",
}
#: The domains of the tables ``check`` and ``compare`` read, by file name.
TABLE_DOMAINS = {"summary.csv": SUMMARY_DOMAINS}
#: Counts that bound each other in one row of ``summary.csv`` (each at most the next).
SUMMARY_COUNT_ORDER = (("n_used", "n_ok"), ("n_warned", "n_ok"), ("n_ok", "n_trials"))
#: The column naming the camera a frame or view was taken by (its id, ``cam0``).
CAMERA_COLUMN = "camera"
#: ``frames.csv``: every frame's detection.
FRAME_COLUMNS = [
    "session",
    "trial",
    "branch",
    "pose",
    CAMERA_COLUMN,
    "frame",
    "log_time_ns",
    "found",
    "col",
    "row",
    "theta_deg",
    "area_px",
    "eccentricity",
    "pi_estimate",
    "n_blobs",
    "n_candidates",
    "reason",
]
#: ``averaging.csv``: the estimate from each trial's first 1..K frames per pose.
AVERAGING_COLUMNS = ["session", "trial", "branch", "n_frames", "units", "x", "y", "z", "err"]
#: One row per used pose: its typed camera centre, combined measurement, the unit ray
#: through the measured pixel (grid frame), and the intrinsics and typed angles (degrees,
#: ``R_cam_to_grid = Rx Ry Rz``) the solver used: with them, the report's top view draws
#: each trial by :func:`twopose.topview.top_view` (``views.csv``).
VIEW_COLUMNS = [
    "session",
    "trial",
    "branch",
    "pose",
    "units",
    "t_x",
    "t_y",
    "t_z",
    "col",
    "row",
    "theta_deg",
    "ray_x",
    "ray_y",
    "ray_z",
    "fx",
    "fy",
    "cx",
    "cy",
    "r_x_deg",
    "r_y_deg",
    "r_z_deg",
]
#: ``rig.csv``: one row per session and rig constant (``units``: the session's, in which
#: the length constants are; the others' unit ends their name, ``_deg``, ``_px``, or none).
RIG_TABLE_COLUMNS = [
    "session",
    "constant",
    "units",
    "value",
    "sigma",
    "fitted",
    "why_fixed",
    "truth",
]
#: ``errors.csv``: one row per input that could not be analysed.
ERROR_COLUMNS = ["session", "error"]
#: The run's tables by file name (``thesis.csv`` and ``sensitivity.csv`` are their
#: modules' own).
RUN_TABLES = {
    "trials.csv": TRIAL_TABLE_COLUMNS,
    "summary.csv": SUMMARY_COLUMNS,
    "averaging.csv": AVERAGING_COLUMNS,
    "frames.csv": FRAME_COLUMNS,
    "views.csv": VIEW_COLUMNS,
    "errors.csv": ERROR_COLUMNS,
    "rig.csv": RIG_TABLE_COLUMNS,
}

# Each column's dtype, one for a name in every table (:func:`typed`
# applies them; :func:`analysis.run_tables.read_table` reads a CSV back to the same).
#: Text: ``str``, "" when there is none, never NaN (in memory as read back).
#: (trials.csv's columns: their declarations' dtypes, which the other tables' columns of the
#: same name share.)
_TEXT = (
    "session", "label", "session_id", "branch", "trials_key", "method", "units", "reason",
    CAMERA_COLUMN, "constant", "why_fixed", "error",
)  # fmt: skip
#: Whole numbers, always known.
_WHOLE = (
    "trial", "pose", "frame", "log_time_ns", "n_blobs", "n_candidates", "n_frames",
    "n_trials", "n_ok", "n_warned", "n_used", "sigma0_dof", "n_flagged",
)  # fmt: skip
#: Every declared column's dtype: ``str`` (text), ``bool`` (always known: a frame's
#: ``found``, a rig constant's ``fitted``), ``boolean`` (pandas' nullable: True, False,
#: or <NA> when not known, as for a trial without a usable covariance), ``int64``, and
#: ``float64`` for every other number (NaN: not measured).
DTYPES: dict[str, str] = {
    **dict.fromkeys((c for columns in RUN_TABLES.values() for c in columns), "float64"),
    **dict.fromkeys(_TEXT, "str"),
    **dict.fromkeys(_WHOLE, "int64"),
    **dict.fromkeys(("found", "fitted", "noise_contradicted"), "bool"),
    **{c.name: c.dtype for c in TRIAL_TABLE},
}


def typed(table: pd.DataFrame, columns: Sequence[str] | None = None) -> pd.DataFrame:
    """``table`` with each declared column as its :data:`DTYPES` dtype: text as ``str``
    with "" where there is none (never NaN, so that a table reads back from its CSV the
    same), flags as ``bool`` or ``boolean``, whole numbers as ``int64``, other numbers as
    ``float64``. With ``columns`` (a table's declared list), only those of them it has,
    in their order (the run's tables concatenated: :func:`analysis.batch.gather`)."""
    if columns is not None:
        table = table[[c for c in columns if c in table.columns]]
    return table.assign(**{c: _as(table[c], DTYPES[c]) for c in table.columns if c in DTYPES})


def _as(values: pd.Series, dtype: str) -> pd.Series:
    """``values`` as ``dtype``; a ``bool`` or ``int64`` column with a missing value (which
    no table should have) as its nullable kin, never a made-up value."""
    from pandas.api.types import pandas_dtype

    if dtype == "str":
        return values.astype(object).where(values.notna(), "").astype("str")
    if dtype in ("bool", "int64") and values.isna().any():
        dtype = "boolean" if dtype == "bool" else "Int64"
    return values.astype(pandas_dtype(dtype))
