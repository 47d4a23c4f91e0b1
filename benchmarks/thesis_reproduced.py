"""The thesis' claims against the bundled thesis sessions: the table docs/sample-sessions.md
shows (``thesis.csv`` of a run over ``sessions/thesis_*.mcap``), as markdown.

    .venv/bin/python benchmarks/thesis_reproduced.py [--write-docs]

Deterministic (the sessions are bundled, the analysis seeded): ``tests/test_docs.py`` reruns
it and compares with the figure the docs include.
"""

from __future__ import annotations

from pathlib import Path

from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from analysis.batch.runner import run
from analysis.report.thesis import THESIS_COLUMNS, thesis_table

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "thesis_reproduced.txt"
SESSIONS = Path(__file__).resolve().parents[1] / "sessions"


def main() -> int:
    result = run(sorted(SESSIONS.glob("thesis_*.mcap")))
    table = thesis_table(result.trials, result.averaging)
    print("| " + " | ".join(THESIS_COLUMNS) + " |")
    print("| " + " | ".join("---" for _ in THESIS_COLUMNS) + " |")
    for _, row in table.iterrows():
        print("| " + " | ".join(str(row[c]).replace("|", "\\|") for c in THESIS_COLUMNS) + " |")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
