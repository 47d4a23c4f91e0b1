"""Benchmark figures written by the benchmarks where the docs include them, never pasted.

A benchmark run with ``--write-docs`` also writes what it prints to
``docs/figures/<name>`` (the command that made it first); the docs page includes that file
(``pymdownx.snippets``), so a figure in the docs is the output of its script's last run.
``tests/test_docs.py`` reruns the deterministic ones and fails when the docs' copy differs.
"""

from __future__ import annotations

import contextlib
import io
import sys
from collections.abc import Iterator
from pathlib import Path

FIGURES = Path(__file__).resolve().parents[1] / "docs" / "figures"

__all__ = ["FIGURES", "recorded"]


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
    FIGURES.mkdir(exist_ok=True)
    (FIGURES / name).write_text(tee.kept.getvalue(), encoding="utf-8")
