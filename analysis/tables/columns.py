"""Every output table's columns, declared once, in the order the files write them.

``docs/analysis.md`` documents each column (``tests/analysis/test_columns.py`` checks that
every one declared here is); the stages that fill a table import its list from here, and
give each column its dtype (:data:`DTYPES`, :func:`typed`: text never NaN, flags boolean),
as :func:`analysis.tables.read_back.read_table` reads the CSV back. What
``trials.csv``'s columns are each one declaration of :mod:`analysis.tables.trials` (name,
label, unit, domain, dtype and what fills it); what depends on the method (its extra
columns, its degeneracy margins) its spec names (:mod:`twopose.methods.specs`).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import TYPE_CHECKING

from analysis.tables.declared import (
    AVERAGING_TABLE,
    FRAME_TABLE,
    SUMMARY_TABLE,
    TABLES,
    VIEW_TABLE,
)
from analysis.tables.trials import TRIAL_TABLE, as_dtype, group

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
    "STREAM_COLUMNS",
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
#: the reprojection-optimal line's errors (twopose.solve.optimal_lines; its point is
#: ``x_optimal``...).
WEIGHTED_COLUMNS = group("line fits")
#: Degeneracy margins (degrees; each method's named by its spec), the warning when one is
#: under its threshold, and the trial's baseline (the longest distance between two typed
#: camera centres).
MARGIN_COLUMNS = group("margins")
#: Point trials: the reprojection-optimal estimate beside the thesis' (x, y, z); line
#: trials: the optimal line's point nearest the true midpoint and its distance from it.
OPTIMAL_COLUMNS = group("optimal")
#: First-order uncertainty of (x, y, z) (:mod:`twopose.uncertainty.propagate`), then the input that
#: dominates the variance, its share, and the frames rejected as outliers.
UNCERTAINTY_COLUMNS = group("uncertainty")
#: The noise model each trial's region assumed (:mod:`twopose.uncertainty.noise`): its placing sigma
#: and
#: where it came from, its misclosure's chi-square and dof, and the widening applied.
NOISE_COLUMNS = group("noise")
#: trials.csv's columns of a two-camera session's touches only (analysis.session.stream_tables):
#: which touch, the clock offset used, the error without interpolation, the skew's share.
STREAM_COLUMNS = group("stream")
#: trials.csv's columns from ``--rig-calibration loo`` (the last five: line trials only).
RIG_COLUMNS = group("rig")
#: ``trials.csv``, every session and method concatenated (a column a method lacks is empty):
#: :data:`analysis.tables.trials.TRIAL_TABLE`, one declaration per column.
TRIAL_TABLE_COLUMNS = [c.name for c in TRIAL_TABLE]
#: The gate's word for each numeric domain of a declaration (:data:`SUMMARY_DOMAINS`).
_GATE_WORDS = {"count": "count", "non-negative": "length", "finite": "signed", "share": "share"}

# The other tables: their declarations (analysis.tables.declared), as lists of names.
#: ``summary.csv``: one row per session and method.
SUMMARY_COLUMNS = [c.name for c in SUMMARY_TABLE]
#: What each number of ``summary.csv`` can be, in the gate's words: ``count`` a whole
#: number >= 0, ``length`` a finite number >= 0, ``signed`` any finite number, ``share``
#: 0 to 1 (each column's declared domain, :data:`analysis.tables.declared.SUMMARY_TABLE`).
#: Empty is "not measured"; anything else outside its domain no run writes, so ``check``
#: and ``compare`` refuse it (:func:`analysis.tables.read_back.check_results_table`).
SUMMARY_DOMAINS: dict[str, str] = {
    c.name: _GATE_WORDS[c.domain.kind] for c in SUMMARY_TABLE if c.domain.kind in _GATE_WORDS
}
#: Every declared table (its columns' declarations) ``check`` and ``compare`` may read,
#: by file name: each value read back is checked against its column's domain.
TABLE_DOMAINS = TABLES
#: Counts that bound each other in one row of ``summary.csv`` (each at most the next).
SUMMARY_COUNT_ORDER = (("n_used", "n_ok"), ("n_warned", "n_ok"), ("n_ok", "n_trials"))
#: The column naming the camera a frame or view was taken by (its id, ``cam0``).
CAMERA_COLUMN = "camera"
#: ``frames.csv``: every frame's detection.
FRAME_COLUMNS = [c.name for c in FRAME_TABLE]
#: ``averaging.csv``: the estimate from each trial's first 1..K frames per pose.
AVERAGING_COLUMNS = [c.name for c in AVERAGING_TABLE]
#: One row per used pose: its typed camera centre, combined measurement, the unit ray
#: through the measured pixel (grid frame), and the intrinsics and typed angles (degrees,
#: ``R_cam_to_grid = Rx Ry Rz``) the solver used: with them, the report's top view draws
#: each trial by :func:`twopose.methods.topview.top_view` (``views.csv``).
VIEW_COLUMNS = [c.name for c in VIEW_TABLE]
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

# Each column's dtype, one for a name in every table (:func:`typed` applies them;
# :func:`analysis.tables.read_back.read_table` reads a CSV back to the same): the declared
# tables' from their declarations (a name in two tables has one dtype,
# tests/analysis/test_columns.py), rig.csv's and errors.csv's listed here.
#: Text: ``str``, "" when there is none, never NaN (in memory as read back).
_TEXT = ("constant", "why_fixed", "error", "session", "units")
#: Every declared column's dtype: ``str`` (text), ``bool`` (always known: a frame's
#: ``found``, a rig constant's ``fitted``), ``boolean`` (pandas' nullable: True, False,
#: or <NA> when not known, as for a trial without a usable covariance), ``int64``, and
#: ``float64`` for every other number (NaN: not measured).
DTYPES: dict[str, str] = {
    **dict.fromkeys((*RIG_TABLE_COLUMNS, *ERROR_COLUMNS), "float64"),
    **dict.fromkeys(_TEXT, "str"),
    "fitted": "bool",
    **{c.name: c.dtype for table in reversed(list(TABLES.values())) for c in table},
}


def typed(table: pd.DataFrame, columns: Sequence[str] | None = None) -> pd.DataFrame:
    """``table`` with each declared column as its :data:`DTYPES` dtype: text as ``str``
    with "" where there is none (never NaN, so that a table reads back from its CSV the
    same), flags as ``bool`` or ``boolean``, whole numbers as ``int64``, other numbers as
    ``float64``. With ``columns`` (a table's declared list), only those of them it has,
    in their order (the run's tables concatenated: :func:`analysis.batch.runner.gather`)."""
    if columns is not None:
        table = table[[c for c in columns if c in table.columns]]
    return table.assign(**{c: as_dtype(table[c], DTYPES[c]) for c in table.columns if c in DTYPES})
