"""The reference of ``trials.csv``'s columns in docs/analysis.md, from their declarations
(:data:`analysis.trial_columns.TRIAL_TABLE`: each column's label, unit, values and methods).

    .venv/bin/python docs/trial_columns_table.py [--write-docs]

Without ``--write-docs`` it compares what it would write with the page and exits 1 on a
difference (``tests/analysis/test_trial_columns.py`` runs the comparison in the quick loop).
"""

from __future__ import annotations

import sys

from marked_table import REPO, write_or_check  # type: ignore[import-not-found]  # docs/ is sys.path[0]


def main() -> int:
    sys.path.insert(0, str(REPO))
    from analysis.trial_columns import markdown_table

    return write_or_check(REPO / "docs" / "analysis.md", "trials.csv columns", markdown_table,
                          "trial_columns_table.py")  # fmt: skip


if __name__ == "__main__":
    sys.exit(main())
