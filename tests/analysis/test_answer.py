"""analysis.report.answer directly: the run's answer per session set and method, pooled over the
sessions and equal to summarize() of the pooled trials, and the numbers as a reader sees
them (two decimals, signed biases with their 95% half-widths, whole percent, "-" unknown)."""

from __future__ import annotations

import math
from pathlib import Path

import pandas as pd
import pytest

from analysis.report.answer import (
    ANSWER_COLUMNS,
    answer_table,
    number,
    readable,
    session_order,
    share,
)
from analysis.session.metrics import summarize


@pytest.mark.parametrize(
    ("value", "signed", "text"),
    [
        (1.234, False, "1.23"),
        (1.235e3, False, "1235.00"),
        (-0.001, True, "+0.00"),  # not -0.00
        (0.5, True, "+0.50"),
        (-2.0, True, "-2.00"),
        (math.nan, False, "-"),
        (None, False, "-"),
        ("x", False, "-"),
    ],
)
def test_number(value: object, signed: bool, text: str) -> None:
    assert number(value, signed=signed) == text


def test_share() -> None:
    assert [share(v) for v in (0.954, 1.0, 0.0, math.nan)] == ["95%", "100%", "0%", "-"]


def test_the_answer_pools_each_set_and_method(bundled_run: Path) -> None:
    trials = pd.read_csv(bundled_run / "trials.csv")
    answer = answer_table(trials)
    assert list(answer.columns) == ANSWER_COLUMNS
    sets = list(dict.fromkeys(answer["set"]))
    assert sets == ["thesis", "stress"]  # the thesis' sessions first
    thesis_points = trials[trials["session"].str.contains("thesis_method1_point")]
    row = answer[(answer["set"] == "thesis") & (answer["method"] == "point")].iloc[0]
    pooled = summarize(thesis_points.assign(session="all")).iloc[0]
    for column in ("n_trials", "n_used", "rmse", "bias_x", "coverage95"):
        assert row[column] == pytest.approx(pooled[column], nan_ok=True), column
    assert answer_table(trials.iloc[:0]).columns.tolist() == ANSWER_COLUMNS


def test_the_readable_answer_says_units_once_and_counts_last(bundled_run: Path) -> None:
    answer = answer_table(pd.read_csv(bundled_run / "trials.csv"))
    table = readable(answer)
    assert list(table.columns[:2]) == ["method", "RMSE (in)"]
    assert list(table.columns[-4:]) == ["trials", "ok", "warned (left out)", "used"]
    assert "units" not in table  # one unit: in the headers
    assert set(table["method"]) == {"point (method 1)", "line", "ground (method 2)"}
    first = answer.iloc[0]
    assert table["RMSE (in)"].iloc[0] == number(first["rmse"])
    assert table["bias x ± 95% (in)"].iloc[0].startswith(number(first["bias_x"], signed=True))
    included = readable(answer, include_warned=True)
    assert "warned (included)" in included
    mixed = readable(
        answer.assign(units=["in", "mm"] * (len(answer) // 2) + ["in"] * (len(answer) % 2))
    )
    assert "units" in mixed
    assert "RMSE" in mixed


def test_session_order_keeps_each_sets_sessions_together(bundled_run: Path) -> None:
    summary = pd.read_csv(bundled_run / "summary.csv")
    ordered = session_order(summary.sample(frac=1.0, random_state=1))
    prefixes = [Path(s).name.split("_", 1)[0] for s in ordered["session"]]
    assert prefixes == sorted(prefixes, key=["thesis", "stress"].index)
