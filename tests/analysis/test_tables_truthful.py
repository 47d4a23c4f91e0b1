"""Issue 56, item 6: every table truthful and complete, on a lab's tree as a hurried analyst
has it (a session forked three ways by three operators, one whose middle continuation
never came off its laptop, a byte copy in a backup folder, a two-trial session): each
finding of the issue, as it was met, with what happens now. The sessions are the lab's
small drawn ones (:mod:`tests.lab`, ``measured=True``): every trial measured, in
milliseconds."""

from __future__ import annotations

import json
import os
import shutil
import struct
from html.parser import HTMLParser
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

import analysis
from analysis.cli import app
from recorder.recover import recover_session
from tests.lab import continue_session, kill_midway, record

runner = CliRunner()


def _run(*args: object) -> str:
    result = runner.invoke(app, [str(a) for a in args], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    return result.output


@pytest.fixture(scope="module")
def lab(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """``lab/``: ``a`` (5 trials) continued three times after trial 5, on day 2 by Bob
    (branch A, 2 trials), on a second laptop by Cy (B, 2 trials) and on a third (C, 1);
    ``b`` continued twice, its middle part left out of the tree; ``c`` (2 trials), with a
    byte copy in ``backup/`` (given first: the folders sort so)."""
    root = tmp_path_factory.mktemp("truthful") / "lab"
    day1, day2, elsewhere = root / "day1", root / "day2", root.parent / "laptop_b"
    for folder in (day1, day2, root / "laptop2", root / "laptop3", root / "backup", elsewhere):
        folder.mkdir(parents=True)
    record(day1 / "a.mcap", 5, measured=True)
    continue_session(day1 / "a.mcap", day2 / "a2.mcap", 2, measured=True, operator="Bob")
    continue_session(day1 / "a.mcap", root / "laptop2" / "a3.mcap", 2, measured=True, operator="Cy")
    continue_session(day1 / "a.mcap", root / "laptop3" / "a4.mcap", 1, measured=True)
    record(day1 / "b.mcap", 1, measured=True)
    continue_session(day1 / "b.mcap", elsewhere / "b2.mcap", 1, measured=True)
    continue_session(elsewhere / "b2.mcap", day2 / "b3.mcap", 1, measured=True)
    record(day1 / "c.mcap", 2, measured=True)
    shutil.copyfile(day1 / "c.mcap", root / "backup" / "c.mcap")
    return root


@pytest.fixture(scope="module")
def lab_run(lab: Path) -> tuple[Path, str]:
    """The lab's run folder and what ``run`` printed."""
    out = lab.parent / "run"
    return out, _run("run", lab, "--out", out, "--no-scene")


class _Tables(HTMLParser):
    """Every ``<table>`` of a page, as rows of cell texts (the header row first), and every
    heading's text."""

    def __init__(self) -> None:
        super().__init__()
        self.tables: list[list[list[str]]] = []
        self.headings: list[str] = []
        self._cell: list[str] | None = None
        self._heading: list[str] | None = None

    def handle_starttag(self, tag: str, attrs: list[tuple[str, str | None]]) -> None:
        if tag == "table":
            self.tables.append([])
        elif tag == "tr" and self.tables:
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = []
        elif tag in ("h2", "h3"):
            self._heading = []

    def handle_endtag(self, tag: str) -> None:
        if tag in ("td", "th") and self._cell is not None:
            self.tables[-1][-1].append("".join(self._cell).strip())
            self._cell = None
        elif tag in ("h2", "h3") and self._heading is not None:
            self.headings.append("".join(self._heading).strip())
            self._heading = None

    def handle_data(self, data: str) -> None:
        for part in (self._cell, self._heading):
            if part is not None:
                part.append(data)


def _page(folder: Path) -> _Tables:
    page = _Tables()
    page.feed((folder / "report.html").read_text(encoding="utf-8"))
    return page


def _table_with(page: _Tables, header: str) -> list[dict[str, str]]:
    """The rows (as dicts) of every table whose header has ``header``, one after another."""
    rows = []
    for table in page.tables:
        if table and header in table[0]:
            rows += [dict(zip(table[0], r, strict=True)) for r in table[1:]]
    return rows


def _per_session(page: _Tables) -> list[dict[str, str]]:
    """The report's per-session table (the answer's tables have no session column)."""
    return [r for r in _table_with(page, "RMSE 95% interval (in)") if "session" in r]


def test_the_truth_inside_its_ellipsoid_is_shown_for_every_trial(lab_run: tuple[Path, str]) -> None:
    """Before: "-" in every row (353 trials of 6 reports) where trials.csv says True/False:
    the nullable column's values are NumPy booleans, which the cell took for unknown."""
    out, _ = lab_run
    trials = pd.read_csv(out / "trials.csv")
    assert trials["within95"].isin([True, False]).all()
    shown = _table_with(_page(out), "truth inside its 95% ellipsoid")
    per_trial = [r for r in shown if "trial" in r]
    assert len(per_trial) == len(trials)
    expected = sorted("yes" if v else "no" for v in trials["within95"])
    assert sorted(r["truth inside its 95% ellipsoid"] for r in per_trial) == expected


def test_no_interval_from_fewer_than_five_trials(lab_run: tuple[Path, str]) -> None:
    """Before: the RMSE's 95% bootstrap interval from 2 trials was their smaller and larger
    error ("0.02 to 0.08"), a t-interval from 2 a number beside each bias."""
    out, _ = lab_run
    summary = pd.read_csv(out / "summary.csv").set_index("label")
    two = summary.loc["day1/c.mcap"]  # its backup's copy beside it: named by its folder
    assert two["n_used"] == 2
    for column in ("rmse_ci95_low", "rmse_ci95_high", "bias_x_ci95", "bias_z_ci95"):
        assert pd.isna(two[column]), column
    seven = summary.loc["a.mcap"]  # branch A: a's 5 trials and a2's 2
    assert seven["n_used"] == 7
    assert seven["rmse_ci95_low"] < seven["rmse"] < seven["rmse_ci95_high"]
    rows = {r["session"]: r for r in _per_session(_page(out))}
    assert rows["day1/c.mcap"]["RMSE 95% interval (in)"] == "none (2 trials: an interval needs 5)"
    assert rows["day1/c.mcap"]["bias x ± 95% (in)"].endswith(" (no interval)")
    assert " to " in rows["a.mcap [branch A]"]["RMSE 95% interval (in)"]


def test_the_branch_is_shown_wherever_a_sessions_trials_are(lab_run: tuple[Path, str]) -> None:
    """Before: the per-session table, the headings and the trial tables never named the
    branch, and branch A's trials (recorded by Bob) were shown under operator "lab"."""
    out, printed = lab_run
    page = _page(out)
    per_session = {r["session"] for r in _per_session(page)}
    assert {"a.mcap [branch A]", "a3.mcap [branch B]", "a4.mcap [branch C]"} <= per_session
    assert {"a.mcap [branch A]", "a3.mcap [branch B]", "a4.mcap [branch C]"} <= set(page.headings)
    branches = {r["branch"] for r in _table_with(page, "branch") if "trial" in r}
    assert branches == {"", "A", "B", "C"}
    metadata = [t for t in page.tables if any(r[:1] == ["operator"] for r in t)]
    operators = {r[1] for t in metadata for r in t if r[:1] == ["operator"]}
    assert "lab (a.mcap: trials 1-5); Bob (a2.mcap: trials 6-7)" in operators
    assert "Cy" in operators  # branch B's own file: its own operator
    assert "a3.mcap [branch B] (point, in)" in printed


def test_counts_of_sessions_count_sessions(lab: Path, lab_run: tuple[Path, str]) -> None:
    """Before: "7 session(s)" for 6 (``info`` and ``run``), a fork's branch and the pieces
    of a session around a missing part counted as sessions of their own."""
    out, printed = lab_run
    said = "3 session(s), taken as 6 (1 forked into 3 branches; 1 split by a missing part)"
    assert f"twopose: {said}, results in" in printed
    assert said in " ".join(_run("info", lab).split())
    document = json.loads((out / "summary.json").read_text())
    assert (document["n_sessions"], document["n_analysed_apart"]) == (3, 6)
    row = next(line for line in printed.splitlines() if line.startswith("point "))
    assert row.split()[1] == "3"  # the per-method table's "sessions"
    page = (out / "report.html").read_text(encoding="utf-8")
    assert f"<p>{said.replace(',', ' analysed,', 1)}, 0 failed" in page
    again = _run("run", lab, "--out", out, "--no-scene")  # the same run, reused: said so
    assert "analysis: 3 of 3 session(s)' reused from the last run" in again


def test_a_session_missing_its_middle_part_says_so(lab_run: tuple[Path, str]) -> None:
    """Before: b3's note said b.mcap's trials were not in the run ("its trials up to 2");
    they were, in a second row of the same session id."""
    out, printed = lab_run
    text = " ".join(printed.split())
    assert "its trials up to 2 are not in this run" not in text
    assert (
        "b2.mcap is not among the inputs: the session is analysed in two pieces with one "
        "session id" in text
    )
    summary = pd.read_csv(out / "summary.csv")
    b_rows = summary[summary["label"].isin(["b.mcap", "b3.mcap"])]
    assert b_rows["session_id"].nunique() == 1
    assert len(b_rows) == 2


def test_the_red_line_counts_what_was_not_analysed(lab_run: tuple[Path, str]) -> None:
    """Before: "0 input(s) failed and 6 not analysed as given": the continuations and the
    forks' notes counted, all of them analysed; only the backup copy was not."""
    out, _ = lab_run
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "0 input(s) failed and 1 not analysed as given" in page
    assert "1 input(s) not analysed as given" in page


def test_a_tie_keeps_the_copy_outside_the_backup_folder_and_says_so(
    lab: Path, lab_run: tuple[Path, str], tmp_path: Path
) -> None:
    """Before: ``backup/c.mcap`` (first in the folders' order) was kept and named the
    session everywhere; ``day1/c.mcap`` was "the same session as backup/c.mcap"."""
    out, printed = lab_run
    text = " ".join(printed.split())
    backup, kept = lab / "backup" / "c.mcap", lab / "day1" / "c.mcap"
    assert f"{backup}: the same session as {kept} (a byte copy); counted once" in text
    assert f"{kept} kept: the copy outside a backup-looking folder" in text
    assert set(pd.read_csv(out / "trials.csv")["session"]) >= {str(kept)}
    # Two copies, neither in a backup folder: the older is kept, whichever is given first.
    old, new = tmp_path / "day1.mcap", tmp_path / "day1_again.mcap"
    shutil.copyfile(kept, old)
    shutil.copyfile(kept, new)
    os.utime(old, (1_000_000_000, 1_000_000_000))
    notes = analysis.run([new, old]).input_notes
    assert (
        f"{new}: the same session as {old} (a byte copy); counted once, {old} kept: the oldest copy"
        in notes
    )


def test_compare_keeps_part_and_branch_and_lists_one_sided_trials(
    lab: Path, lab_run: tuple[Path, str]
) -> None:
    """Before: paired.csv had no part or branch (trial 6 of three branches, three rows
    alike), side_by_side.csv pooled the three branches in one row, and nothing said that
    only one run held a4.mcap's trial."""
    out, _ = lab_run
    fewer = lab.parent / "fewer"
    _run("run", lab / "day1", lab / "day2", lab / "laptop2", "--out", fewer, "--no-scene")
    comparison = lab.parent / "comparison"
    printed = _run("compare", out, fewer, "--out", comparison)
    paired = pd.read_csv(comparison / "paired.csv", keep_default_na=False)
    assert {"part", "branch"} <= set(paired.columns)
    sixes = paired[paired["trial"] == 6]
    assert sorted(sixes["branch"]) == ["A", "B"]
    assert sixes["part"].nunique() == 2
    side = pd.read_csv(comparison / "side_by_side.csv", keep_default_na=False)
    a_rows = side[side["session"].str.startswith("a")]
    assert sorted(a_rows["branch"]) == ["A", "B", "C"]
    assert a_rows.set_index("branch").loc["A", "n_used_a"] == 7
    one_sided = pd.read_csv(comparison / "one_sided.csv", keep_default_na=False)
    assert one_sided[["session", "branch", "trial", "held_by"]].values.tolist() == [
        ["a4.mcap", "C", 6, "A"]
    ]
    assert "only in A: a4.mcap [branch C] (point): trial 6" in printed


def test_recover_says_where_and_why_the_file_ended(tmp_path: Path) -> None:
    """Before: ``the file ended early: EndOfFile: `` (the reader's error has no message)."""
    cut = tmp_path / "cut.mcap"
    record(cut, 3, measured=True)
    kill_midway(cut, keep=0.3)  # in the data: the summary is most of so small a file
    said = recover_session(cut, tmp_path / "fixed.mcap").summary()
    line = next(x for x in said.splitlines() if "ended early" in x)
    assert "EndOfFile" not in line
    assert not line.rstrip().endswith(":")
    assert "runs past the end of the file" in line
    assert "the recording was not closed" in line


def test_recover_of_a_file_cut_between_records_says_so(tmp_path: Path) -> None:
    """Before: a file cut exactly after a whole record said its last record, "from byte N,
    runs past the end of the file (N bytes)"."""
    whole = tmp_path / "whole.mcap"
    record(whole, 2, measured=True)
    data = whole.read_bytes()
    # The footer's summary start, less the data end record (opcode, length, crc: 13 bytes).
    summary_start = struct.unpack_from("<Q", data, len(data) - 8 - 29 + 9)[0]
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: summary_start - 13])
    report = recover_session(cut, tmp_path / "fixed.mcap")
    line = next(x for x in report.summary().splitlines() if "ended early" in x)
    assert "runs past" not in line
    assert f"the file ends after its last whole record, at byte {summary_start - 13:,}" in line
    assert report.chunks_lost == 0
    assert report.chunks_kept > 0


def test_figures_name_sessions_by_their_labels(tmp_path: Path) -> None:
    """Before: ``x/session.mcap`` was titled ``x_session`` (a file-name stem), and
    ``session.mcap`` and ``session.MCAP`` were both "session"."""
    from analysis.report.figures.draw import make_figures

    for where in ("x/session.mcap", "y/session.mcap", "z/session.MCAP"):
        (tmp_path / where).parent.mkdir(parents=True, exist_ok=True)
        record(tmp_path / where, 1, measured=True)
    result = analysis.run([tmp_path / "x", tmp_path / "y", tmp_path / "z"])
    figures = make_figures(result)
    titles = {
        fig.axes[0].get_title() for name, fig in figures.items() if name.startswith("scatter")
    }
    assert titles == {
        "x/session.mcap: estimate - truth",
        "y/session.mcap: estimate - truth",
        "session.MCAP: estimate - truth",
    }
    legend = figures["error_by_trial"].legends[0]
    assert {t.get_text() for t in legend.get_texts()} >= {
        "x/session.mcap",
        "y/session.mcap",
        "session.MCAP",
    }
