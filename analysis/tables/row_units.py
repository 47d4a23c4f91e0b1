"""What one row of ``trials.csv`` is, by its session's cameras: a trial or a touch.

A one-camera session's row is a **trial** (its typed poses' estimate); a two-camera
session's row is a **touch** (a moment the operator marked while a stream trial's frames
flowed: :mod:`analysis.session.stream_tables`). The ``cameras`` column (1 or 2) of
``trials.csv``, ``summary.csv`` and ``averaging.csv`` says which; this registry holds the
words every output uses for such rows (the terminal's summary, the verdicts, the report's
tables, captions and legends, ``check`` and ``compare``), so that a two-camera session's
rows are called touches everywhere and a one-camera session's trials, and a run of both
says each of its kinds by its own word. A table without the column (an older run's, a
table built by hand) is one camera's.
"""

from __future__ import annotations

import math
from collections.abc import Iterable
from dataclasses import dataclass
from typing import Literal

import pandas as pd

__all__ = ["ROW_UNITS", "RowUnit", "row_unit", "row_units_of", "rows_counted", "rows_word"]


@dataclass(frozen=True, kw_only=True)
class RowUnit:
    """What a row is in a session of ``cameras`` cameras, in words."""

    cameras: int
    #: The row's noun, and its plural.
    noun: str
    plural: str
    #: What its running average averages (``averaging.csv``'s ``n_frames`` of them), and
    #: which n of them.
    averaged: str
    averaged_from: str
    #: The running averages' x axis, in words.
    averaged_count: str

    def count(self, n: int) -> str:
        """``n`` rows in words: ``1 touch``, ``4 touches``."""
        return f"{n} {self.noun if n == 1 else self.plural}"

    @property
    def maybe_plural(self) -> str:
        """The noun for a count said beside it: ``trial(s)``, ``touch(es)``."""
        return f"{self.noun}({self.plural.removeprefix(self.noun)})"

    def numbered(self, row: pd.Series) -> str:
        """A row named: ``trial 3``; a touch by its ``touch`` column where it has one
        (``trial 2, touch 1``), else ``touch 5`` (its number in the session)."""
        said = row.get("touch") if self.cameras == 2 else None
        if isinstance(said, str) and said:
            return said
        return f"{self.noun} {int(row['trial'])}"


#: The row units, by the session's cameras.
ROW_UNITS: dict[int, RowUnit] = {
    1: RowUnit(
        cameras=1,
        noun="trial",
        plural="trials",
        averaged="frames",
        averaged_from="the first n frames of each pose",
        averaged_count="number of frames averaged per pose",
    ),
    2: RowUnit(
        cameras=2,
        noun="touch",
        plural="touches",
        averaged="pair estimates about the touch",
        averaged_from="the n pair estimates nearest the touch",
        averaged_count="number of pair estimates averaged about the touch",
    ),
}


def row_unit(cameras: object = 1) -> RowUnit:
    """The unit of a row whose ``cameras`` is this (missing, empty or NaN: one camera)."""
    try:
        n = float(cameras)  # type: ignore[arg-type]
    except (TypeError, ValueError):
        return ROW_UNITS[1]
    return ROW_UNITS.get(int(n), ROW_UNITS[1]) if math.isfinite(n) else ROW_UNITS[1]


def row_units_of(table: pd.DataFrame | pd.Series) -> tuple[RowUnit, ...]:
    """The units of a table's rows (or of one row), each once, trials first; one camera's
    when it has no ``cameras`` column (or no rows)."""
    if isinstance(table, pd.Series):
        return (row_unit(table.get("cameras", 1)),)
    if "cameras" not in table or table.empty:
        return (ROW_UNITS[1],)
    found = {row_unit(c).cameras for c in table["cameras"].unique()}
    return tuple(ROW_UNITS[n] for n in sorted(found))


def rows_word(
    table: pd.DataFrame | pd.Series,
    form: Literal["plural", "noun", "maybe_plural"] = "plural",
    *,
    joiner: str = " and ",
) -> str:
    """The rows of ``table`` in one word, or two joined (``trials``, ``touches``, ``trials
    and touches``; ``form`` ``noun``: ``trial``, ``maybe_plural``: ``trial(s)``)."""
    return joiner.join(getattr(u, form) for u in row_units_of(table))


def rows_counted(
    table: pd.DataFrame, counts: str | None = None, *, ok: bool = False, least: int = 0
) -> str:
    """How many rows ``table`` has, each kind by its word: ``15 trial(s)``, ``93 trial(s)
    and 60 touch(es)``; with ``counts``, the sum of that column per kind (a summary's
    ``n_warned``), kinds with fewer than ``least`` left out; ``ok``: ``ok`` before the word."""
    cameras = table["cameras"] if "cameras" in table else pd.Series(1, index=table.index)
    kinds = cameras.map(lambda c: row_unit(c).cameras)
    weights = (
        pd.Series(1, index=table.index)
        if counts is None
        else pd.to_numeric(table[counts], errors="coerce").fillna(0)
    )
    said = []
    for unit in row_units_of(table):
        n = int(weights[kinds == unit.cameras].sum())
        if n >= least:
            said.append(f"{n} {'ok ' if ok else ''}{unit.maybe_plural}")
    return _joined(said) or f"0 {ROW_UNITS[1].maybe_plural}"


def _joined(words: Iterable[str]) -> str:
    return " and ".join(words)
