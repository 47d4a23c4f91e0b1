"""analysis.report.captions directly: a run figure's caption names the trials it draws and the
largest error per session set and method, the answer table's "largest"; a session's caption
says what became of its warned and failed trials."""

from __future__ import annotations

import re
from pathlib import Path

import pandas as pd
import pytest

from analysis.report.answer import answer_table
from analysis.report.captions import largest_errors, run_captions, session_captions


@pytest.fixture(scope="module")
def trials(bundled_run: Path) -> pd.DataFrame:
    return pd.read_csv(bundled_run / "trials.csv")


def test_the_largest_error_drawn_is_the_answers(trials: pd.DataFrame) -> None:
    answer = answer_table(trials)
    largest = largest_errors(trials, include_warned=False)
    assert len(largest) == len(answer)
    for name, method, value in largest:
        row = answer[(answer["set"] == name) & (answer["method"] == method)].iloc[0]
        assert value == pytest.approx(row["max_err"])
    caption = run_captions(trials, include_warned=False)["error_histogram"]
    marked = re.findall(r"data-set='(\w+)' data-method='(\w+)'>([\d.]+)</span>", caption)
    assert [(s, m, f"{v:.2f}") for s, m, v in largest] == marked
    assert "Errors in inches" in caption or "errors in inches" in caption


def test_which_trials_a_run_figure_draws(trials: pd.DataFrame) -> None:
    n_warned = int((trials["status"].eq("ok") & trials["warning"].fillna("").ne("")).sum())
    assert n_warned > 0  # the stress sessions warn
    left_out = run_captions(trials, include_warned=False)["error_by_trial"]
    assert f"({n_warned} warned trial(s) left out, as there)" in left_out
    kept = run_captions(trials, include_warned=True)["error_by_trial"]
    assert f"the {n_warned} warned included (--include-warned)" in kept
    assert run_captions(trials.iloc[:0], include_warned=False) == {}


def test_a_sessions_captions_say_what_became_of_its_trials(trials: pd.DataFrame) -> None:
    session = trials[trials["session"].str.contains("stress_method2_ground")]
    n_warned = int((session["status"].eq("ok") & session["warning"].fillna("").ne("")).sum())
    n_not_ok = int(session["status"].ne("ok").sum())
    captions = session_captions(session, include_warned=False)
    assert set(captions) == {"scatter", "topview", "averaging"}
    assert "the ground point the finger points at" in captions["topview"]
    assert n_warned > 0  # the stress session warns
    assert f"{n_warned} warned trial(s) hollow, without an ellipse" in captions["scatter"]
    assert (
        "one colour in all of this session's figures (the key at the right)" in captions["topview"]
    )
    assert "framed by the trials the statistics use" in captions["scatter"]
    assert "framed" not in session_captions(session, include_warned=True)["scatter"]
    assert "left out of the statistics" in captions["scatter"]
    assert f"{n_warned} warned trial(s) dashed, left out" in captions["averaging"]
    assert ("not ok are not drawn" in captions["averaging"]) == (n_not_ok > 0)
    failed = session.assign(status=["degenerate"] + ["ok"] * (len(session) - 1))
    assert (
        "1 trial(s) not ok are not drawn."
        in session_captions(failed, include_warned=True)["scatter"]
    )
