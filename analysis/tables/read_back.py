"""A finished run's tables read back (``check``, ``compare``): checked, or refused in words.

:func:`read_table` reads a run's CSV as the run held it in memory (each declared column's
dtype, :data:`analysis.tables.columns.DTYPES`: text "" where empty, never NaN; flags boolean);
:func:`read_results_table` reads one and checks it (:func:`check_results_table`: the
columns, one row per key, numbers, each inside its column's domain, counts adding up); its
sessions are named by :func:`session_keys`, so that two runs of the same sessions from
different places match.
"""

from __future__ import annotations

import csv
import math
import os
from collections.abc import Iterable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING

from twopose.errors import InputValueError

if TYPE_CHECKING:
    import pandas as pd

    from analysis.tables.trials import Column

__all__ = [
    "NA_TEXTS",
    "check_results_table",
    "read_results_table",
    "read_table",
    "refusals",
    "session_keys",
]

#: What a number's cell reads as "not measured" (pandas' defaults; a run writes "").
NA_TEXTS = (
    "", "#N/A", "#N/A N/A", "#NA", "-1.#IND", "-1.#QNAN", "-NaN", "-nan", "1.#IND",
    "1.#QNAN", "<NA>", "N/A", "NA", "NULL", "NaN", "None", "n/a", "nan", "null",
)  # fmt: skip
#: A flag's cell (``within95``; ``1.0`` and ``0.0`` as runs before the flags were
#: boolean wrote them), any case; empty: not known.
_FLAG_WORDS = {"true": True, "1": True, "1.0": True, "false": False, "0": False, "0.0": False}


def read_table(path: str | Path) -> pd.DataFrame:
    """``path``, a CSV table a run wrote, with the dtypes the run's table had in memory
    (:func:`analysis.tables.columns.typed`): declared text columns as ``str``, an empty cell
    ``""`` (so "NA" in the notes stays "NA"); declared flags as ``bool``, or ``boolean``
    (<NA>: not known) when a cell is empty; numbers as pandas reads them, an empty cell
    NaN. A flag's cell that is not one is kept as written, for the caller to refuse.
    Raises what :func:`pandas.read_csv` raises (OSError, ValueError...)."""
    import pandas as pd

    from analysis.tables.columns import DTYPES

    with open(path, encoding="utf-8", newline="") as fh:
        header = next(csv.reader(fh), [])
    text = [c for c in header if DTYPES.get(c) in ("str", "bool", "boolean")]
    table = pd.read_csv(
        path,
        dtype=dict.fromkeys(text, "str"),
        keep_default_na=False,
        na_values={c: list(NA_TEXTS) for c in header if c not in text},
    )
    for column in text:
        if DTYPES[column] != "str" and column in table.columns:
            table[column] = _flags(table[column], DTYPES[column])
    return table


def _flags(cells: pd.Series, dtype: str) -> pd.Series:
    """A flag column's cells (text) as ``dtype``, ``boolean`` when one is empty; as written
    (empty cells NaN) when one is not a flag."""
    words = cells.str.strip().str.lower()
    empty = words.eq("")
    flags = words.map(_FLAG_WORDS)
    if (flags.isna() & ~empty).any():
        return flags.astype(object).where(flags.notna(), cells.where(~empty))
    return flags.astype("boolean" if empty.any() or dtype == "boolean" else "bool")


def read_results_table(
    folder: str | Path,
    name: str,
    *,
    key: Sequence[str] = ("session", "method"),
    required: Iterable[str] = (),
    numeric: Iterable[str] = (),
) -> pd.DataFrame:
    """``folder/name``, a CSV table a run wrote, checked as ``check`` and ``compare`` need
    it (:func:`check_results_table`), or an error saying what is wrong and what to do; the
    columns' dtypes as the run had them (:func:`read_table`)."""
    where = Path(folder)
    path = where / name
    if not where.is_dir():
        raise InputValueError(f"{folder} is not a folder: give a run's --out folder")
    if not path.is_file():  # a FIFO or a device would block the read forever
        raise InputValueError(
            f"no {name} in {folder}: give the --out folder of a finished `twopose-analyze run`"
        )
    try:
        with open(path, encoding="utf-8", newline="") as fh:
            header = next(csv.reader(fh), [])
    except (OSError, ValueError, UnicodeDecodeError, csv.Error) as err:
        raise InputValueError(f"cannot read {path}: {err}") from err
    # Before pandas reads it: a column given twice (a flag's above all) is no table to type.
    twice = sorted({c for c in header if header.count(c) > 1})
    if twice:
        raise InputValueError(f"{path}: column(s) {', '.join(twice)} given twice")
    try:
        table = read_table(path)
    except (OSError, ValueError, UnicodeDecodeError, csv.Error) as err:
        raise InputValueError(f"cannot read {path}: {err}") from err
    from analysis.tables.declared import TABLES

    return check_results_table(
        table, str(path), key=key, required=required, numeric=numeric, columns=TABLES.get(name)
    )


def check_results_table(
    table: pd.DataFrame,
    what: str,
    *,
    key: Sequence[str] = ("session", "method"),
    required: Iterable[str] = (),
    numeric: Iterable[str] = (),
    columns: Iterable[Column] | None = None,
) -> pd.DataFrame:
    """The one check of a run's table before ``check`` or ``compare`` reads it: the
    ``key`` and ``required`` columns present, every row with its key, no key twice (a
    session and method, or a trial, in two rows: which is the run's?), the ``numeric``
    columns present numbers or empty (not measured), and with ``columns`` (the table's
    declarations, :data:`analysis.tables.declared.TABLES`) every value inside its column's
    declared domain and the counts adding up. Returns ``table``."""
    import pandas as pd

    missing = [c for c in (*key, *required) if c not in table.columns]
    if missing:
        raise InputValueError(
            f"{what} has no column {', '.join(missing)}: not a table of this twopose's run; "
            "run `twopose-analyze run` again to write it"
        )
    blank = table[list(key)].isna().any(axis=1) | (
        table[list(key)].astype(str).apply(lambda c: c.str.strip()).eq("").any(axis=1)
    )
    if blank.any():
        rows = ", ".join(str(i + 1) for i in table.index[blank][:5])
        raise InputValueError(
            f"{what}: row(s) {rows} (below the header) have no {' or '.join(key)}"
        )
    keyed = table.assign(session=session_keys(table["session"])) if "session" in key else table
    doubled = keyed[keyed.duplicated(list(key), keep=False)]
    if len(doubled):
        names = sorted({_key_name(key, row) for row in doubled[list(key)].itertuples(index=False)})
        shown = "; ".join(names[:5]) + (f"; and {len(names) - 5} more" if len(names) > 5 else "")
        raise InputValueError(
            f"{what}: more than one row for {shown}; a run writes one per "
            f"{', '.join(key)}: which is the run's? Keep one and check again"
        )
    for column in numeric:
        if column not in table.columns:
            continue
        values = pd.to_numeric(table[column], errors="coerce")
        bad = values.isna() & table[column].notna()
        if bad.any():
            i = table.index[bad][0]
            value = table[column][i]
            raise InputValueError(
                f"{what}: {column} in row {i + 1} (below the header) is {value!r}, not a number"
            )
    if columns is not None:
        _check_domains(table, what, columns)
    return table


def _check_domains(table: pd.DataFrame, what: str, columns: Iterable[Column]) -> None:
    """Refuse a value no run can write (:func:`refusals`), naming the first five."""
    problems = refusals(table, columns)
    if problems:
        more = f"; and {len(problems) - 5} more" if len(problems) > 5 else ""
        shown = "; ".join(problems[:5]) + more
        raise InputValueError(
            f"{what}: values no run writes: {shown}. Was it edited by hand? Run "
            "`twopose-analyze run` again to write it"
        )


def refusals(table: pd.DataFrame, columns: Iterable[Column]) -> list[str]:
    """Every value of ``table`` no run can write, in words (none: it is as declared):
    outside its column's declared domain (a number's cell that is no number, infinite or
    out of range, a text that is not one of its values), or counts that do not add up
    (more trials used than ok). Empty cells are "not measured", but for a count."""
    import pandas as pd

    from analysis.tables.columns import SUMMARY_COUNT_ORDER

    problems: list[str] = []
    for column in columns:
        if column.name not in table.columns:
            continue
        values = table[column.name]
        for i in values.index[column.domain.outside(values)]:
            problems.append(
                f"{column.name} = {_shown(values[i])} in row {int(str(i)) + 1} "
                f"({column.domain.words})"
            )
    for low, high in SUMMARY_COUNT_ORDER:
        if low in table.columns and high in table.columns:
            a, b = (pd.to_numeric(table[c], errors="coerce") for c in (low, high))
            for i in table.index[(a > b).fillna(value=False)]:
                problems.append(f"{low} = {a[i]:g} > {high} = {b[i]:g} in row {int(str(i)) + 1}")
    return problems


def _shown(value: object) -> str:
    """A cell as a refusal names it: a number as ``%g``, an empty one ``empty``, any
    other value quoted."""
    if isinstance(value, float | int) and not isinstance(value, bool):
        return "empty" if math.isnan(value) else f"{value:g}"
    return repr(value)


def _key_name(key: Sequence[str], values: Iterable[object]) -> str:
    """``a.mcap (point)``, ``a.mcap (point) trial 3``: a row's key as the messages name it."""
    named = [str(v) for v in values]
    extra = "".join(f" {k} {v}" for k, v in zip(key[2:], named[2:], strict=True))
    return f"{named[0]} ({named[1]}){extra}" if len(named) > 1 else named[0]


def session_keys(sessions: pd.Series) -> pd.Series:
    """Each session's path below the run's common folder: ``sessions/a.mcap`` and
    ``/ci/clone/sessions/a.mcap`` are both ``a.mcap``, so that two runs of the same
    sessions from different places match."""
    paths = [str(s) for s in sessions]
    parents = {os.path.dirname(p) for p in paths}
    try:
        common = os.path.commonpath(list(parents)) if parents and "" not in parents else ""
    except ValueError:  # absolute and relative paths mixed
        common = ""
    return sessions.map(lambda s: os.path.relpath(str(s), common) if common else str(s))
