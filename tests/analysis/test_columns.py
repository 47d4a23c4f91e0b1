"""analysis.tables.columns: each table's columns are declared once, documented, and written.

The run's files carry exactly the declared columns, in the declared order; the core's
uncertainty columns are the ones declared; and docs/analysis.md names every column
(``sigma_x/y/z`` naming three).
"""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.tables.columns import (
    AVERAGING_COLUMNS,
    FRAME_COLUMNS,
    MARGIN_COLUMNS,
    RIG_COLUMNS,
    STREAM_COLUMNS,
    SUMMARY_COLUMNS,
    TRIAL_TABLE_COLUMNS,
    UNCERTAINTY_COLUMNS,
    VIEW_COLUMNS,
)
from twopose.methods.specs import METHOD_SPECS
from twopose.uncertainty.propagate import SPREAD_COLUMNS, uncertainty_columns

DOCS = Path(__file__).resolve().parents[2] / "docs" / "analysis.md"

FILES = {
    "trials.csv": TRIAL_TABLE_COLUMNS,
    "summary.csv": SUMMARY_COLUMNS,
    "frames.csv": FRAME_COLUMNS,
    "averaging.csv": AVERAGING_COLUMNS,
    "views.csv": VIEW_COLUMNS,
}


def documented_names(text: str) -> set[str]:
    """Every column name in the backquoted spans of ``text``, ``a_x/y/z_s`` expanded."""
    names: set[str] = set()
    for span in re.findall(r"`([^`]+)`", text):
        for token in re.split(r"[,\s]+", span):
            names |= _expand(token.strip("()"))
    return names


def _expand(token: str) -> set[str]:
    """``sigma_x/y/z`` -> sigma_x, sigma_y, sigma_z; ``bias_x/y/z_ci95`` -> bias_*_ci95."""
    parts = token.split("/")
    if len(parts) == 1:
        return {token}
    stem, first = parts[0].rsplit("_", 1) if "_" in parts[0] else ("", parts[0])
    last, _, suffix = parts[-1].partition("_")
    middles = [first, *parts[1:-1], last]
    tail = f"_{suffix}" if suffix else ""
    return {f"{stem}_{m}{tail}".lstrip("_") for m in middles} | {parts[0]}


def test_the_expansion_reads_the_docs_abbreviations() -> None:
    assert documented_names("`sigma_x/y/z`") >= {"sigma_x", "sigma_y", "sigma_z"}
    assert documented_names("`bias_x/y/z_ci95`") >= {"bias_x_ci95", "bias_y_ci95", "bias_z_ci95"}
    assert documented_names("`rmse_ci95_low/high`") >= {"rmse_ci95_low", "rmse_ci95_high"}
    assert "sigma_w" not in documented_names("`sigma_x/y/z`")


@pytest.mark.parametrize("name", FILES)
def test_every_declared_column_is_documented(name: str) -> None:
    missing = [c for c in FILES[name] if c not in documented_names(DOCS.read_text())]
    assert not missing, f"{name}: columns missing from docs/analysis.md: {missing}"


def test_each_table_declares_a_column_once() -> None:
    for name, columns in FILES.items():
        assert len(set(columns)) == len(columns), name


def test_the_methods_margins_and_the_core_uncertainty_columns_are_the_declared_ones() -> None:
    margins = {m for spec in METHOD_SPECS.values() for m in spec.margins}
    assert margins <= set(MARGIN_COLUMNS)
    assert len(margins) == 3
    error, cov = np.zeros((2, 3)), np.stack([np.eye(3)] * 2)
    spread = uncertainty_columns(error, cov)
    assert list(spread) == list(SPREAD_COLUMNS) == UNCERTAINTY_COLUMNS[: len(SPREAD_COLUMNS)]
    assert all(len(v) == 2 for v in spread.values())


@pytest.mark.parametrize("name", FILES)
def test_the_run_writes_the_declared_columns_in_order(bundled_run: Path, name: str) -> None:
    table = pd.read_csv(bundled_run / name)
    assert len(table) > 0
    # The rig's columns come with --rig-calibration loo only (test_pipeline runs it), the
    # stream's with a two-camera session only (test_stream_run runs one).
    later = {*RIG_COLUMNS, *STREAM_COLUMNS} if name == "trials.csv" else set()
    expected = [c for c in FILES[name] if c not in later]
    assert list(table.columns) == expected
