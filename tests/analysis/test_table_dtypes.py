"""The Python face's tables carry the dtypes their columns declare, and read back the same.

``analysis.run``'s DataFrames and its CSVs read back as the project reads them
(:func:`analysis.tables.read_back.read_table`) are equal, dtypes included: text is ``str`` with ""
where there is none (never NaN), flags are boolean (``within95`` <NA> when not known),
every table with a length in it names its ``units``.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import analysis
from analysis.results import RunResult
from analysis.tables.columns import DTYPES, RUN_TABLES, TRIAL_TABLE_COLUMNS, typed
from analysis.tables.read_back import read_results_table, read_table

#: The tables a run without ``--rig-calibration`` writes, by file and RunResult attribute.
WRITTEN = {"trials.csv": "trials", "summary.csv": "summary", "averaging.csv": "averaging"}
WRITTEN |= {"frames.csv": "frames", "views.csv": "views"}


@pytest.fixture(scope="module")
def line_run(
    line_session: Path, tmp_path_factory: pytest.TempPathFactory
) -> tuple[RunResult, Path]:
    """One small line session (2 trials, no warning, no notes) run into a folder."""
    out = tmp_path_factory.mktemp("dtypes") / "out"
    return analysis.run([line_session], out, scene=False), out


@pytest.mark.parametrize("name", WRITTEN)
def test_a_table_has_its_declared_dtypes_and_reads_back_equal(
    line_run: tuple[RunResult, Path], name: str
) -> None:
    result, out = line_run
    table = getattr(result, WRITTEN[name])
    assert len(table) > 0
    for column in table.columns:
        declared = DTYPES[column]
        if declared in ("bool", "boolean"):
            assert table[column].dtype == declared, column
        elif declared == "str":
            assert pd.api.types.is_string_dtype(table[column]), column
            assert table[column].notna().all(), column  # "" where there is none
    back = read_table(out / name)
    pd.testing.assert_frame_equal(back, table.reset_index(drop=True))


def test_empty_text_and_unknown_flags_are_the_same_in_memory_and_read_back(
    line_run: tuple[RunResult, Path],
) -> None:
    result, out = line_run
    trials = result.trials
    assert list(trials["warning"]) == list(trials["notes"]) == ["", ""]
    assert trials["within95"].dtype == "boolean"
    back = read_results_table(out, "trials.csv", key=("session", "method", "trial"))
    assert list(back["warning"]) == list(back["notes"]) == ["", ""]
    assert back["within95"].dtype == "boolean"


def test_every_table_with_a_length_names_its_units(line_run: tuple[RunResult, Path]) -> None:
    result, _ = line_run
    for name in ("trials.csv", "summary.csv", "averaging.csv", "views.csv", "rig.csv"):
        assert "units" in RUN_TABLES[name], name
    for table in (result.trials, result.summary, result.averaging, result.views):
        assert set(table["units"]) == {"in"}
    # frames.csv is in pixels (and degrees), errors.csv has no number
    assert "units" not in RUN_TABLES["frames.csv"]


def test_typed_fills_what_a_concatenation_leaves_missing() -> None:
    """A column one session's table lacks: text "", a flag <NA>, a number NaN."""
    a = pd.DataFrame({"session": ["a"], "trial": [1], "notes": ["x"], "within95": [1.0]})
    b = pd.DataFrame({"session": ["b"], "trial": [2], "x": [0.5]})
    table = typed(pd.concat([a, b], ignore_index=True), TRIAL_TABLE_COLUMNS)
    assert list(table.columns) == ["session", "trial", "x", "within95", "notes"]
    assert list(table["notes"]) == ["x", ""]
    assert table["within95"].dtype == "boolean"
    assert table["within95"].isna().tolist() == [False, True]
    assert table["trial"].dtype == np.int64
    empty = typed(pd.DataFrame(columns=RUN_TABLES["frames.csv"]))
    assert empty["found"].dtype == bool
    assert pd.api.types.is_string_dtype(empty["camera"])


def test_flags_as_older_runs_wrote_them_read_as_flags(tmp_path: Path) -> None:
    (tmp_path / "t.csv").write_text("trial,within95,notes\n1,1.0,NA\n2,0.0,\n3,,nan\n")
    table = read_table(tmp_path / "t.csv")
    assert table["within95"].dtype == "boolean"
    assert table["within95"].tolist()[:2] == [True, False]
    assert table["within95"].isna().tolist() == [False, False, True]
    assert list(table["notes"]) == ["NA", "", "nan"]  # the operator's words, as written


_TEXT = st.text(st.characters(blacklist_categories=("Cs", "Cc")), max_size=12)


@settings(max_examples=40, deadline=None)
@given(
    st.lists(
        st.tuples(_TEXT, _TEXT, st.sampled_from([True, False, None]), st.booleans()),
        min_size=1,
        max_size=5,
    )
)
def test_any_text_and_flags_round_trip_through_the_csv(
    tmp_path_factory: pytest.TempPathFactory,
    rows: list[tuple[str, str, bool | None, bool]],
) -> None:
    table = typed(
        pd.DataFrame(
            {
                "notes": [r[0] for r in rows],
                "warning": [r[1] for r in rows],
                "within95": pd.array([r[2] for r in rows], dtype="boolean"),
                "found": [r[3] for r in rows],
            }
        )
    )
    path = tmp_path_factory.mktemp("roundtrip") / "t.csv"
    path.write_bytes(table.to_csv(index=False).encode("utf-8"))
    pd.testing.assert_frame_equal(read_table(path), table)
