"""The table of every environment setting in docs/bad-input.md, from the code's one list
(:data:`twopose.values.environment.ENVIRONMENT`).

    .venv/bin/python docs/environment_table.py [--write-docs]

Without ``--write-docs`` it compares what it would write with the page and exits 1 on a
difference (``tests/twopose/test_environment.py`` runs the comparison in the quick loop).
"""

from __future__ import annotations

import sys

from marked_table import REPO, write_or_check  # type: ignore[import-not-found]  # docs/ is sys.path[0]


def main() -> int:
    sys.path.insert(0, str(REPO))
    from twopose.values.environment import markdown_table

    return write_or_check(REPO / "docs" / "bad-input.md", "environment table", markdown_table,
                          "environment_table.py")  # fmt: skip


if __name__ == "__main__":
    sys.exit(main())
