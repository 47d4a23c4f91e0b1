"""How the report shows a table that is not the answer: every column's label in words, its
unit in the header, and its cells with the answer's rounding (:func:`analysis.report.answer.number`:
two decimals, signed errors, shares in percent, yes/no for flags).

One registry (:data:`LABELS`): a column's name, its kind (how a cell reads) and whether
its header carries the session's unit. ``trials.csv``'s columns' labels are read from their
declarations (:data:`analysis.tables.trials.TRIAL_TABLE`: label, unit kind, domain and
dtype); the other tables' columns are listed here. The CSV files keep their names; the
report shows these.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping
from dataclasses import dataclass
from types import MappingProxyType

import numpy as np
import pandas as pd

from analysis.report.answer import number, share
from analysis.tables.trials import TRIAL_TABLE, Column
from twopose.methods.specs import METHODS, label_of
from twopose.values.units import DEFAULT_UNITS, Units, unit_factor

__all__ = [
    "LABELS",
    "MAX_LEGEND",
    "Label",
    "common_units",
    "label_of_column",
    "metadata_table",
    "readable_columns",
    "table_units",
    "unit_label",
]


#: Series in one legend (a figure's, a caption's list); beyond it, colours are keyed by a
#: colour bar. Here, not with the figures' style, so that a run that draws no figure never
#: imports matplotlib (issue 47: a re-run's fixed cost).
MAX_LEGEND = 8


def common_units(trials: pd.DataFrame) -> tuple[pd.DataFrame, str]:
    """``trials`` with their lengths in one unit, and its name: the sessions' own when they
    share one, else every length converted to inches."""
    units = sorted({str(u) for u in trials["units"]}) if "units" in trials else []
    if len(units) == 1:
        return trials, units[0]
    if not units:
        return trials, "session units"
    scale = trials["units"].map(lambda u: unit_factor(u, DEFAULT_UNITS)).astype(float)
    lengths = ("err", "err_x", "err_y", "err_z", "semiaxis95", "baseline")
    converted = {c: trials[c] * scale for c in lengths if c in trials}
    inches: pd.DataFrame = trials.assign(**converted)
    return inches, str(DEFAULT_UNITS)


def _count(value: object) -> str:
    if isinstance(value, np.number):  # NumPy's integers are no Python int
        value = value.item()
    if not isinstance(value, int | float) or math.isnan(value):
        return "-"
    return f"{int(value)}"


def _flag(value: object) -> str:
    """yes, no, or ``-`` when not known. A nullable boolean column (``within95``) yields
    NumPy's booleans, which are no Python ``int``: read as the truth values they are."""
    if isinstance(value, str):
        value = {"true": 1.0, "false": 0.0, "1": 1.0, "0": 0.0}.get(value.strip().lower(), value)
    if isinstance(value, np.bool_ | np.number):
        value = value.item()
    if not isinstance(value, int | float) or math.isnan(value):
        return "-"
    return "yes" if value else "no"


def _text(value: object) -> str:
    if value is None or (isinstance(value, float) and math.isnan(value)):
        return ""
    return str(value)


def _plain(value: object) -> str:
    """A value as given (a sweep's setting): up to four significant digits."""
    if isinstance(value, int | float) and not isinstance(value, bool):
        return "-" if math.isnan(value) else f"{value:.4g}"
    return _text(value)


#: How a cell of each kind reads.
_FORMAT: Mapping[str, Callable[[object], str]] = MappingProxyType(
    {
        "length": number,
        "signed": lambda v: number(v, signed=True),
        "angle": number,
        "share": share,
        "count": _count,
        "flag": _flag,
        "text": _text,
        "plain": _plain,
        "method": label_of,
    }
)


@dataclass(frozen=True)
class Label:
    """A column as the report shows it: ``name`` in words, ``kind`` (a key of the cell
    formats), and the header's unit: ``"session"`` (the table's length unit), a fixed
    one (``"°"``), or none."""

    name: str
    kind: str
    unit: str = ""


_LENGTH = "session"
#: The header's unit of each unit kind of a declared column (``squared length``: none, as
#: the session's unit squared has no name of its own here).
_HEADER_UNIT: Mapping[str, str] = MappingProxyType({"length": _LENGTH, "degrees": "°"})


def label_of_column(column: Column) -> Label:
    """How the report shows a declared ``trials.csv`` column: its label, a cell kind from its
    dtype, unit and domain (a length that can be negative is signed; the methods' names as
    their labels), and its unit in the header."""
    if column.domain.values and set(column.domain.values) == set(METHODS):
        kind = "method"
    elif column.dtype == "str":
        kind = "text"
    elif column.dtype in ("bool", "boolean"):
        kind = "flag"
    elif column.dtype == "int64":
        kind = "count"
    elif column.unit == "share":
        kind = "share"
    elif column.unit == "degrees":
        kind = "angle"
    elif column.unit in ("length", "squared length"):
        kind = "signed" if column.domain.kind == "finite" else "length"
    else:
        kind = "plain"
    return Label(column.label, kind, _HEADER_UNIT.get(column.unit, ""))


#: Every column the report shows outside the answer and the per-session summary.
LABELS: Mapping[str, Label] = MappingProxyType(
    {
        **{column.name: label_of_column(column) for column in TRIAL_TABLE},
        "error": Label("why it failed", "text"),
        # the rig correction's before and after (--rig-calibration loo)
        "trials": Label("trials", "count"),
        "rmse": Label("RMSE", "length", _LENGTH),
        "rmse_rig_loo": Label("RMSE, rig corrected (leave one out)", "length", _LENGTH),
        "coverage95": Label("truth inside its 95% ellipsoid", "share"),
        "coverage95_rig": Label("the same, rig corrected", "share"),
        "systematic_dominant": Label("trials the rig dominates", "count"),
        "constant": Label("constant", "text"),
        "value": Label("value", "plain"),
        "sigma": Label("1-sigma", "plain"),
        "fitted": Label("fitted", "flag"),
        "why_fixed": Label("why fixed", "text"),
        "truth": Label("truth (simulated)", "plain"),
        # a sensitivity sweep
        "sweep": Label("input varied", "text"),
        "unit": Label("its unit", "text"),
    }
)

#: A session's metadata keys as the report names them (others: underscores as spaces).
_METADATA_NAMES: Mapping[str, str] = MappingProxyType(
    {
        "format_version": "session format version",
        "notes": "recorder's notes",
        "simulated": "simulated",
    }
)


def readable_columns(table: pd.DataFrame, units: Units | None = None) -> pd.DataFrame:
    """``table`` with each column of :data:`LABELS` in words (lengths' headers naming
    ``units``) and its cells as the answer rounds them; other columns kept as they are."""
    out: dict[str, object] = {}
    for column in table.columns:
        label = LABELS.get(str(column))
        if label is None:
            out[str(column)] = table[column]
            continue
        unit = (units or "") if label.unit == _LENGTH else label.unit
        header = f"{label.name} ({unit})" if unit else label.name
        out[header] = [_FORMAT[label.kind](v) for v in table[column]]
    return pd.DataFrame(out, index=table.index)


def metadata_table(metadata: Mapping[str, str]) -> pd.DataFrame:
    """A session's metadata as two columns of words (the operator's notes are shown apart,
    by the report, so they are left out here)."""
    shown = {k: v for k, v in metadata.items() if k not in _SHOWN_APART}
    names = [_METADATA_NAMES.get(k, k.replace("_", " ")) for k in shown]
    values = [_metadata_value(k, v) for k, v in shown.items()]
    return pd.DataFrame({"": names, " ": values})


_SHOWN_APART = ("operator_notes", "trial_notes")


def _metadata_value(key: str, value: str) -> str:
    if key == "method":
        return label_of(value)
    return {"True": "yes", "False": "no"}.get(value, value)


def table_units(trials: pd.DataFrame, recorded: str = "") -> Units | None:
    """The length unit ``trials`` share, else ``recorded`` (a session's metadata, when it
    has no trial); None when neither says one (or the trials are in several units)."""
    units = set(trials["units"].astype(str)) if "units" in trials else set()
    if not units and recorded:
        units = {recorded}
    return Units(units.pop()) if len(units) == 1 else None


def unit_label(units: Units | None) -> str:
    """How axes and captions name a length unit ("session units" when it is not known)."""
    return Units(units).value if units is not None else "session units"
