"""The table of every typed quantity's bound in docs/recording.md, from the code's one table
(:data:`twopose.values.bounds.QUANTITIES`).

    .venv/bin/python docs/bounds_table.py [--write-docs]

Without ``--write-docs`` it compares what it would write with the page and exits 1 on a
difference (``tests/twopose/test_bounds.py`` runs the comparison in the quick loop).
"""

from __future__ import annotations

import sys

from marked_table import REPO, write_or_check  # type: ignore[import-not-found]  # docs/ is sys.path[0]


def main() -> int:
    sys.path.insert(0, str(REPO))
    from twopose.values.bounds import markdown_table

    return write_or_check(REPO / "docs" / "recording.md", "bounds table", markdown_table,
                          "bounds_table.py")  # fmt: skip


if __name__ == "__main__":
    sys.exit(main())
