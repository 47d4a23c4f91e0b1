"""The output tables: every column declared once, the rows, the tables read back.

The columns of every table (``columns``), ``trials.csv``'s declared columns (``trials``) and
its noise columns (``noise``), the rows of frames, trials, views and averaging (``rows``),
the tables' words for a reader (``labels``) and a finished run's tables read back for
``check`` and ``compare`` (``read_back``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from twopose.lazy import lazy_exports

if TYPE_CHECKING:
    from analysis.tables.columns import (
        AVERAGING_COLUMNS,
        ERROR_COLUMNS,
        FRAME_COLUMNS,
        RIG_COLUMNS,
        RIG_TABLE_COLUMNS,
        SUMMARY_COLUMNS,
        SUMMARY_DOMAINS,
        TRIAL_TABLE_COLUMNS,
        VIEW_COLUMNS,
        typed,
    )
    from analysis.tables.declared import SUMMARY_TABLE
    from analysis.tables.labels import (
        MAX_LEGEND,
        common_units,
        metadata_table,
        readable_columns,
        table_units,
        unit_label,
    )
    from analysis.tables.read_back import check_results_table, read_results_table
    from analysis.tables.rows import (
        averaging_table,
        frame_row,
        view_table,
        with_branch,
        with_identity,
    )
    from analysis.tables.trials import columns_of, trial_table

__all__ = [
    "AVERAGING_COLUMNS",
    "ERROR_COLUMNS",
    "FRAME_COLUMNS",
    "MAX_LEGEND",
    "RIG_COLUMNS",
    "RIG_TABLE_COLUMNS",
    "SUMMARY_COLUMNS",
    "SUMMARY_DOMAINS",
    "SUMMARY_TABLE",
    "TRIAL_TABLE_COLUMNS",
    "VIEW_COLUMNS",
    "averaging_table",
    "check_results_table",
    "columns_of",
    "common_units",
    "frame_row",
    "metadata_table",
    "read_results_table",
    "readable_columns",
    "table_units",
    "trial_table",
    "typed",
    "unit_label",
    "view_table",
    "with_branch",
    "with_identity",
]

#: Where each exported name lives; it is imported from there on first use.
_HOMES = {
    "AVERAGING_COLUMNS": "analysis.tables.columns",
    "ERROR_COLUMNS": "analysis.tables.columns",
    "FRAME_COLUMNS": "analysis.tables.columns",
    "MAX_LEGEND": "analysis.tables.labels",
    "RIG_COLUMNS": "analysis.tables.columns",
    "RIG_TABLE_COLUMNS": "analysis.tables.columns",
    "SUMMARY_COLUMNS": "analysis.tables.columns",
    "SUMMARY_DOMAINS": "analysis.tables.columns",
    "SUMMARY_TABLE": "analysis.tables.declared",
    "TRIAL_TABLE_COLUMNS": "analysis.tables.columns",
    "VIEW_COLUMNS": "analysis.tables.columns",
    "averaging_table": "analysis.tables.rows",
    "check_results_table": "analysis.tables.read_back",
    "columns_of": "analysis.tables.trials",
    "common_units": "analysis.tables.labels",
    "frame_row": "analysis.tables.rows",
    "metadata_table": "analysis.tables.labels",
    "read_results_table": "analysis.tables.read_back",
    "readable_columns": "analysis.tables.labels",
    "table_units": "analysis.tables.labels",
    "trial_table": "analysis.tables.trials",
    "typed": "analysis.tables.columns",
    "unit_label": "analysis.tables.labels",
    "view_table": "analysis.tables.rows",
    "with_branch": "analysis.tables.rows",
    "with_identity": "analysis.tables.rows",
}

__getattr__, __dir__ = lazy_exports("analysis.tables", _HOMES, __all__)
