"""The reference of ``trials.csv``'s columns in docs/analysis.md, from their declarations
(:data:`analysis.trial_columns.TRIAL_TABLE`: each column's label, unit, values and methods).

    .venv/bin/python docs/trial_columns_table.py [--write-docs]

Without ``--write-docs`` it compares what it would write with the page and exits 1 on a
difference (``tests/analysis/test_trial_columns.py`` runs the comparison in the quick loop).
"""

from __future__ import annotations

import sys
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
PAGE = REPO / "docs" / "analysis.md"
BEGIN = "<!-- trials.csv columns: written by docs/trial_columns_table.py --write-docs -->\n"
END = "<!-- end of the trials.csv columns -->\n"


def written(page: str) -> str:
    """``page`` with the table between its markers as the code states it."""
    sys.path.insert(0, str(REPO))
    from analysis.trial_columns import markdown_table

    head, rest = page.split(BEGIN, 1)
    _, tail = rest.split(END, 1)
    return head + BEGIN + markdown_table() + END + tail


def main() -> int:
    page = PAGE.read_text("utf-8")
    new = written(page)
    if "--write-docs" in sys.argv[1:]:
        PAGE.write_text(new, "utf-8")
        return 0
    if new != page:
        print(
            f"{PAGE.relative_to(REPO)}: the trials.csv columns' table is stale; run: "
            ".venv/bin/python docs/trial_columns_table.py --write-docs"
        )
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
