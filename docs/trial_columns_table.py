"""The references of the run's tables' columns in docs/analysis.md, from their declarations
(:data:`analysis.tables.trials.TRIAL_TABLE`: each column's label, unit, values and methods;
:data:`analysis.tables.declared.TABLES`: the other tables').

    .venv/bin/python docs/trial_columns_table.py [--write-docs]

Without ``--write-docs`` it compares what it would write with the page and exits 1 on a
difference (``tests/analysis/test_trial_columns.py`` runs the comparison in the quick loop).
"""

from __future__ import annotations

import sys
from functools import partial

from marked_table import REPO, write_or_check  # type: ignore[import-not-found]  # docs/ is sys.path[0]


def main() -> int:
    sys.path.insert(0, str(REPO))
    from analysis.tables.declared import TABLES, column_reference
    from analysis.tables.trials import markdown_table

    page, script = REPO / "docs" / "analysis.md", "trial_columns_table.py"
    stale = write_or_check(page, "trials.csv columns", markdown_table, script)
    for name, columns in TABLES.items():
        if name != "trials.csv":
            table = partial(column_reference, columns)
            stale |= write_or_check(page, f"{name} columns", table, script)
    return stale


if __name__ == "__main__":
    sys.exit(main())
