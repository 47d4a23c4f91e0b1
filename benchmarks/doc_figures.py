"""Benchmark figures written by the benchmarks where the docs include them, never pasted.

Every benchmark ends with ``raise SystemExit(run_recorded(main, FIGURE))``. Run with
``--write-docs`` anywhere on its command line, it prints as usual and also writes what it
printed to ``docs/figures/<figure>``; the docs page includes that file
(``pymdownx.snippets``), so a figure in the docs is the output of its script's last run, whether
the run met its targets or not. ``tests/test_docs.py`` checks that every benchmark has its
figure and that a page includes it, and reruns the deterministic ones to compare.
"""

from __future__ import annotations

import contextlib
import io
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

FIGURES = Path(__file__).resolve().parents[1] / "docs" / "figures"
WRITE_DOCS = "--write-docs"

__all__ = ["FIGURES", "WRITE_DOCS", "recorded", "run_recorded"]


class _Tee(io.TextIOBase):
    """Text written to the terminal and kept."""

    def __init__(self, terminal: io.TextIOBase) -> None:
        self.terminal, self.kept = terminal, io.StringIO()

    def write(self, text: str) -> int:
        self.terminal.write(text)
        return self.kept.write(text)

    def flush(self) -> None:
        self.terminal.flush()


@contextlib.contextmanager
def recorded(name: str, *, write: bool) -> Iterator[None]:
    """Print as usual; with ``write``, also save the output to ``docs/figures/<name>``."""
    if not write:
        yield
        return
    tee = _Tee(sys.stdout)  # type: ignore[arg-type]
    with contextlib.redirect_stdout(tee):
        yield
    # Written whether the run met its targets or not (the docs show what the script printed,
    # never an older, better run), but not after an exception or Ctrl-C: half a run is no figure.
    FIGURES.mkdir(exist_ok=True)
    (FIGURES / name).write_text(tee.kept.getvalue(), encoding="utf-8")


def finished(started: float, missed: list[str]) -> int:
    """A benchmark's last lines: its time since ``started`` (``time.perf_counter``), each
    target it missed; its exit code (1 when one was missed)."""
    print(f"({time.perf_counter() - started:.0f} s)")
    for line in missed:
        print(f"target missed: {line}")
    return 1 if missed else 0


def run_recorded(main: Callable[[], int | None], figure: str) -> int:
    """Run a benchmark's ``main``; ``--write-docs`` (taken off ``sys.argv``) records its output."""
    write = WRITE_DOCS in sys.argv
    sys.argv = [a for a in sys.argv if a != WRITE_DOCS]
    with recorded(figure, write=write):
        return main() or 0
