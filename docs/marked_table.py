"""A generated table between two markers of a docs page, written or checked: the one
``--write-docs`` mechanism of docs/bounds_table.py and docs/trial_columns_table.py.

Without ``--write-docs`` a script compares what it would write with the page and exits 1
on a difference (the tests run the comparison in the quick loop).
"""

from __future__ import annotations

import sys
from collections.abc import Callable
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]


def write_or_check(page: Path, what: str, table: Callable[[], str], script: str) -> int:
    """Write ``table()`` between ``page``'s markers for ``what`` (``--write-docs``), or
    check that it is there; the exit code (1: stale, the message says how to refresh)."""
    begin = f"<!-- {what}: written by docs/{script} --write-docs -->\n"
    end = f"<!-- end of the {what} -->\n"
    text = page.read_text("utf-8")
    head, rest = text.split(begin, 1)
    _, tail = rest.split(end, 1)
    new = head + begin + table() + end + tail
    if "--write-docs" in sys.argv[1:]:
        page.write_text(new, "utf-8")
        return 0
    if new != text:
        print(
            f"{page.relative_to(REPO)}: its {what} are not the code's; run: "
            f".venv/bin/python docs/{script} --write-docs"
        )
        return 1
    return 0
