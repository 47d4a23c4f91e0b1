"""analysis.tables.declared: every table the run writes is declared as trials.csv is, and
``check`` and ``compare`` refuse, in words, any value of any table they read that its
column's declaration does not allow (issue 57 item 5).

Before, frames, views, averaging and summary were lists of names, only ``summary.csv``'s
numbers were checked, and a malformed ``trials.csv`` (a status no run writes, a negative
error, a trial number 2.5) was read by ``compare`` and ``check`` as if it were a run's.
"""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from analysis.cli import app
from analysis.tables.columns import DTYPES, RUN_TABLES, STREAM_COLUMNS
from analysis.tables.declared import TABLES
from analysis.tables.read_back import read_results_table, read_table, refusals
from analysis.tables.trials import violations
from twopose.errors import InputValueError

runner = CliRunner()

#: A value outside each kind of domain (a number's cell that is no number: "finite").
_BAD = {
    "count": "2.5",
    "non-negative": "-1",
    "share": "1.5",
    "finite": "abc",
    "flag": "maybe",
    "one of": "bogus",
}
#: How ``check`` and ``compare`` key each table they read.
_KEYS = {"trials.csv": ("session", "method", "trial"), "summary.csv": ("session", "method")}


def test_every_table_is_written_as_declared(bundled_run: Path) -> None:
    """Each declared table's file has its declared columns in their order, every value
    inside its column's domain, and each column's dtype the one declared (a name in two
    tables, one dtype)."""
    for name, columns in TABLES.items():
        names = [c.name for c in columns]
        assert names == RUN_TABLES[name], name
        assert len(set(names)) == len(names), name
        written = read_table(bundled_run / name)
        # in order; trials.csv's rig columns only with --rig-calibration loo, the stream's
        # only with a two-camera session (the bundled sessions are one camera's)
        assert list(written.columns) == [c for c in names if c in written.columns], name
        optional = {c for c in names if "rig" in c} | set(STREAM_COLUMNS)
        assert set(names) - set(written.columns) <= optional, name
        assert not violations(written, columns), name
        for c in columns:
            assert DTYPES[c.name] == c.dtype, (name, c.name)


@pytest.mark.parametrize("name", sorted(_KEYS))
def test_a_value_outside_any_declared_column_is_refused_naming_it(
    bundled_run: Path, tmp_path: Path, name: str
) -> None:
    """Every column of the tables ``check`` and ``compare`` read, each with one bad value
    in a row of its own: each refused, naming the column, the value and its row; the
    table read back as they read it, from its file."""
    checked = [
        c for c in TABLES[name] if c.domain.kind in _BAD and c.name not in _KEYS[name]
    ]  # text can be anything; a key has its own refusal
    table = pd.read_csv(bundled_run / name, dtype=str, keep_default_na=False)
    table = table.sample(len(checked), replace=True, random_state=0).reset_index(drop=True)
    table = table.reindex(columns=[c.name for c in TABLES[name]], fill_value="")  # the rig's
    table["session"] = [f"s{i}.mcap" for i in range(len(table))]  # one row per key
    expected = []
    for i, column in enumerate(checked):
        bad = _BAD[column.domain.kind]
        table.loc[i, column.name] = bad
        shown = bad if column.domain.kind in ("count", "non-negative", "share") else repr(bad)
        expected.append(f"{column.name} = {shown} in row {i + 1} ({column.domain.words})")
    table.to_csv(tmp_path / name, index=False)
    said = refusals(read_table(tmp_path / name), TABLES[name])
    assert [s for s in said if " > " not in s] == expected  # n_ok > n_trials: counts too
    with pytest.raises(InputValueError, match=f"values no run writes: {re.escape(expected[0])}"):
        read_results_table(tmp_path, name, key=_KEYS[name])


def test_compare_refuses_a_malformed_trials_table_in_words(
    bundled_run: Path, tmp_path: Path
) -> None:
    run = tmp_path / "run"
    shutil.copytree(bundled_run, run, ignore=shutil.ignore_patterns("*.mcap", "*.png"))
    trials = pd.read_csv(run / "trials.csv", dtype=str, keep_default_na=False)
    trials.loc[2, "status"] = "fine"
    trials.to_csv(run / "trials.csv", index=False)
    result = runner.invoke(app, ["compare", str(bundled_run), str(run), "--out", str(tmp_path)])
    assert result.exit_code == 3, result.output
    assert "status = 'fine' in row 3 (one of ok, degenerate, no_detection, incomplete)" in (
        result.output
    )
    assert "Traceback" not in result.output


def test_check_refuses_a_malformed_trials_table_beside_the_summary(
    bundled_run: Path, tmp_path: Path
) -> None:
    """``check`` reads each run's trials.csv too (to compare sessions over the trials both
    hold): a negative error there is refused, not compared."""
    run = tmp_path / "run"
    shutil.copytree(bundled_run, run, ignore=shutil.ignore_patterns("*.mcap", "*.png"))
    trials = pd.read_csv(run / "trials.csv", dtype=str, keep_default_na=False)
    trials.loc[0, "err"] = "-0.5"
    trials.to_csv(run / "trials.csv", index=False)
    result = runner.invoke(app, ["check", str(run), "--baseline", str(bundled_run)])
    assert result.exit_code == 3, result.output
    assert "err = -0.5 in row 1" in result.output
    assert "Traceback" not in result.output
