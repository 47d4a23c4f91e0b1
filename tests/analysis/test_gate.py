"""The CI gate: ``check`` against a baseline, tolerances, JUnit XML, ``summary.json``."""

from __future__ import annotations

import json
import shutil
import xml.etree.ElementTree as ET
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from analysis.cli import app
from analysis.gate.baseline import Tolerance, check, load_tolerance
from analysis.tables.read_back import session_keys
from twopose.errors import InputValueError

runner = CliRunner()


@pytest.fixture(scope="module")
def baseline(
    tmp_path_factory: pytest.TempPathFactory, point_session: Path, ground_session: Path
) -> Path:
    out = tmp_path_factory.mktemp("gate") / "baseline"
    junit = out.parent / "run.xml"
    result = runner.invoke(
        app,
        [
            "run",
            str(point_session),
            str(ground_session),
            "--out",
            str(out),
            "--no-scene",
            "--junit",
            str(junit),
        ],
    )
    assert result.exit_code == 0, result.output
    return out


def _copy(baseline: Path, tmp_path: Path) -> Path:
    run = tmp_path / "run"
    shutil.copytree(baseline, run)
    return run


def _edit(run: Path, method: str, **changes: float) -> None:
    summary = pd.read_csv(run / "summary.csv")
    for column, factor in changes.items():
        summary.loc[summary["method"] == method, column] *= factor
    summary.to_csv(run / "summary.csv", index=False)


def test_a_run_checked_against_itself_passes(baseline: Path, tmp_path: Path) -> None:
    junit = tmp_path / "check.xml"
    result = runner.invoke(
        app, ["check", str(baseline), "--baseline", str(baseline), "--junit", str(junit)]
    )
    assert result.exit_code == 0, result.output
    assert "checked 2 session/method pair(s)" in result.output
    assert "no regression" in result.output
    suite = ET.parse(junit).getroot()
    assert suite.get("tests") == "2"
    assert suite.get("failures") == "0"


def test_a_worse_rmse_is_printed_with_its_size_and_fails(baseline: Path, tmp_path: Path) -> None:
    run = _copy(baseline, tmp_path)
    _edit(run, "ground", rmse=1.5)
    junit = tmp_path / "check.xml"
    result = runner.invoke(
        app, ["check", str(run), "--baseline", str(baseline), "--junit", str(junit)]
    )
    assert result.exit_code == 1, result.output
    line = next(x for x in result.output.splitlines() if x.startswith("REGRESSED"))
    assert "ground.mcap (ground) rmse:" in line
    assert "+50%" in line
    assert "1 regression(s)" in result.output
    cases = ET.parse(junit).getroot().findall(".//testcase")
    assert sorted(c.get("classname", "") for c in cases) == ["twopose.ground", "twopose.point"]
    failed = [c for c in cases if c.find("failure") is not None]
    assert [c.get("name") for c in failed] == ["ground.mcap"]
    failure = failed[0].find("failure")
    assert failure is not None
    assert "rmse" in failure.get("message", "")


def test_worse_within_tolerance_is_printed_but_passes(baseline: Path, tmp_path: Path) -> None:
    run = _copy(baseline, tmp_path)
    _edit(run, "point", median_err=1.05)  # 5% worse; the default allows 10%
    result = runner.invoke(app, ["check", str(run), "--baseline", str(baseline)])
    assert result.exit_code == 0, result.output
    assert "worse point.mcap (point) median_err" in result.output


def test_fewer_ok_trials_and_lower_coverage_regress(baseline: Path, tmp_path: Path) -> None:
    run = _copy(baseline, tmp_path)
    summary = pd.read_csv(run / "summary.csv")
    summary["n_ok"] -= 1  # and what it bounds with it: the counts still add up
    summary["n_used"] = summary[["n_used", "n_ok"]].min(axis=1)
    summary["n_warned"] = summary[["n_warned", "n_ok"]].min(axis=1)
    summary["coverage95"] = (summary["coverage95"] - 0.5).clip(lower=0.0)
    summary.to_csv(run / "summary.csv", index=False)
    outcome = check(run, baseline)
    regressed = outcome.comparisons[outcome.comparisons["status"] == "regressed"]
    assert set(regressed["metric"]) == {"n_ok", "coverage95"}
    assert outcome.regressed


def test_a_session_missing_from_the_run_regresses(baseline: Path, tmp_path: Path) -> None:
    run = _copy(baseline, tmp_path)
    summary = pd.read_csv(run / "summary.csv")
    summary[summary["method"] == "point"].to_csv(run / "summary.csv", index=False)
    result = runner.invoke(app, ["check", str(run), "--baseline", str(baseline)])
    assert result.exit_code == 1
    assert "REGRESSED ground.mcap (ground): in the baseline, not in this run" in result.output
    # The other way round, a session only in the run is new: reported, not a failure.
    back = runner.invoke(app, ["check", str(baseline), "--baseline", str(run)])
    assert back.exit_code == 0, back.output
    assert "new: ground.mcap (ground)" in back.output


def test_a_tolerance_file_loosens_one_method(baseline: Path, tmp_path: Path) -> None:
    run = _copy(baseline, tmp_path)
    _edit(run, "ground", rmse=1.2)
    tolerance = tmp_path / "tolerance.toml"
    tolerance.write_text("[rmse]\nabsolute = 0.0\n\n[methods.ground.rmse]\nrelative = 0.25\n")
    assert runner.invoke(app, ["check", str(run), "--baseline", str(baseline)]).exit_code == 1
    result = runner.invoke(
        app, ["check", str(run), "--baseline", str(baseline), "--tolerance", str(tolerance)]
    )
    assert result.exit_code == 0, result.output
    tolerances = load_tolerance(tolerance)
    assert tolerances["ground"].rmse.relative == 0.25
    assert tolerances[""].rmse.relative == Tolerance().rmse.relative  # given in part: kept


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[rmse]\nrelativ = 0.1\n", "unknown key(s) rmse.relativ"),
        ("[rmse]\nrelative = -0.1\n", "cannot be negative"),
        ("[rmse]\nrelative = 'ten'\n", "rmse.relative must be a finite number"),
        ("rmse = [\n", "not valid TOML"),
        ("methods = 3\n", "methods must be a table"),
    ],
)
def test_a_bad_tolerance_file_is_refused_with_the_key(
    baseline: Path, tmp_path: Path, text: str, message: str
) -> None:
    tolerance = tmp_path / "tolerance.toml"
    tolerance.write_text(text)
    result = runner.invoke(
        app, ["check", str(baseline), "--baseline", str(baseline), "--tolerance", str(tolerance)]
    )
    assert result.exit_code == 3, result.output
    assert message in result.output


def test_a_folder_without_a_summary_is_refused(baseline: Path, tmp_path: Path) -> None:
    result = runner.invoke(app, ["check", str(tmp_path), "--baseline", str(baseline)])
    assert result.exit_code == 3
    assert "no summary.csv in" in result.output
    assert "Traceback" not in result.output


def test_run_writes_junit_and_summary_json(baseline: Path) -> None:
    cases = ET.parse(baseline.parent / "run.xml").getroot().findall(".//testcase")
    found = sorted((c.get("classname"), Path(c.get("name") or "").name) for c in cases)
    assert found == [("twopose.ground", "ground.mcap"), ("twopose.point", "point.mcap")]
    assert all(c.find("failure") is None for c in cases)
    document = json.loads((baseline / "summary.json").read_text())
    summary = pd.read_csv(baseline / "summary.csv")
    assert document["n_sessions"] == 2
    assert document["n_failed"] == 0
    assert [row["method"] for row in document["methods"]] == ["ground", "point"]
    assert [row["rmse"] for row in document["summary"]] == pytest.approx(list(summary["rmse"]))
    assert set(document["summary"][0]) == set(summary.columns)
    assert document["verdict"]


def test_run_junit_fails_the_case_of_a_session_that_failed(tmp_path: Path) -> None:
    broken = tmp_path / "broken.mcap"
    broken.write_bytes(b"\x89MCAP0\r\nnot really")
    junit = tmp_path / "run.xml"
    result = runner.invoke(
        app, ["run", str(broken), "--out", str(tmp_path / "out"), "--junit", str(junit)]
    )
    assert result.exit_code == 1
    cases = ET.parse(junit).getroot().findall(".//testcase")
    assert len(cases) == 1
    assert cases[0].find("failure") is not None


def test_session_keys_match_runs_from_different_places() -> None:
    here = pd.Series(["sessions/a.mcap", "sessions/sub/b.mcap"])
    there = pd.Series(["/ci/clone/sessions/a.mcap", "/ci/clone/sessions/sub/b.mcap"])
    assert list(session_keys(here)) == list(session_keys(there)) == ["a.mcap", "sub/b.mcap"]


def test_the_bundled_sessions_match_the_committed_baseline(bundled_run: Path) -> None:
    """docs/ci.md's job, on our own sessions: .ci/baseline/summary.csv is current."""
    ci = Path(__file__).resolve().parents[2] / ".ci"
    args = ["check", str(bundled_run), "--baseline", str(ci / "baseline")]
    result = runner.invoke(app, [*args, "--tolerance", str(ci / "tolerance.toml")])
    assert result.exit_code == 0, result.output
    assert "checked 7 session/method pair(s)" in result.output
    assert load_tolerance(ci / "tolerance.toml")["ground"].rmse.relative == 0.15


@pytest.mark.parametrize(
    ("column", "value", "said"),
    [
        ("rmse", -1.0, "rmse = -1"),
        ("rmse", float("-inf"), "rmse = -inf"),
        ("rmse", float("inf"), "rmse = inf"),
        ("coverage95", 7.0, "coverage95 = 7"),
        ("n_ok", 2.5, "n_ok = 2.5"),
        ("n_used", 999.0, "n_used = 999 > n_ok"),
        ("bias_x", float("inf"), "bias_x = inf"),
    ],
)
@pytest.mark.parametrize("side", ["run", "baseline"])
def test_values_no_run_writes_are_refused_on_either_side(
    baseline: Path, tmp_path: Path, column: str, value: float, said: str, side: str
) -> None:
    """A gate that knows what cannot be: exit 3 naming the value, in the run or the
    baseline, never 'no regression' (an RMSE of -1 or -inf is no measurement)."""
    edited = _copy(baseline, tmp_path)
    summary = pd.read_csv(edited / "summary.csv")
    summary[column] = summary[column].astype(float)
    summary.loc[0, column] = value
    summary.to_csv(edited / "summary.csv", index=False)
    run, base = (edited, baseline) if side == "run" else (baseline, edited)
    result = runner.invoke(app, ["check", str(run), "--baseline", str(base)])
    assert result.exit_code == 3, result.output
    assert said in result.output
    assert "values no run writes" in result.output


def test_an_empty_baseline_metric_is_said_not_passed_silently(
    baseline: Path, tmp_path: Path
) -> None:
    edited = _copy(baseline, tmp_path)
    summary = pd.read_csv(edited / "summary.csv")
    summary.loc[0, "rmse"] = float("nan")
    summary.to_csv(edited / "summary.csv", index=False)
    result = runner.invoke(app, ["check", str(baseline), "--baseline", str(edited)])
    assert result.exit_code == 0, result.output
    assert "not compared: rmse of" in result.output
    assert "the baseline has no value for it" in result.output


@pytest.mark.parametrize("relative", [5, 1.5, float("inf")])
def test_a_tolerance_beyond_doubling_is_refused(tmp_path: Path, relative: float) -> None:
    path = tmp_path / "tolerance.toml"
    path.write_text(f"[rmse]\nrelative = {'inf' if relative == float('inf') else relative}\n")
    with pytest.raises(InputValueError, match=r"relative tolerance|'inf' is not a number"):
        load_tolerance(path)
    path.write_text("[rmse]\nrelative = 1.0\n")
    assert load_tolerance(path)[""].rmse.relative == 1.0


def test_an_output_that_is_a_hard_link_to_an_input_is_refused(
    baseline: Path, tmp_path: Path
) -> None:
    """``check --junit`` naming a hard link to the baseline's summary.csv: the rename would
    leave the original intact, but an output never names an input, by any name."""
    import os

    run = _copy(baseline, tmp_path)
    link = tmp_path / "elsewhere.xml"
    os.link(baseline / "summary.csv", link)
    before = (baseline / "summary.csv").read_bytes()
    result = runner.invoke(
        app, ["check", str(run), "--baseline", str(baseline), "--junit", str(link)]
    )
    assert result.exit_code == 3, result.output
    assert "hard link" in result.output
    assert str(baseline / "summary.csv") in result.output
    assert (baseline / "summary.csv").read_bytes() == before
    # a hard link to a session, as rig's --out
    session = tmp_path / "s.mcap"
    shutil.copy(
        next(iter(sorted(Path(__file__).resolve().parents[2].glob("sessions/*.mcap")))), session
    )
    other = tmp_path / "rig.toml"
    os.link(session, other)
    result = runner.invoke(app, ["rig", str(session), "--out", str(other)])
    assert result.exit_code == 3, result.output
    assert "is the input" in result.output


# -- Issue 56: a gate that sees what was left out; allowances that carry units ---------


@pytest.fixture(scope="module")
def parallax_runs(tmp_path_factory: pytest.TempPathFactory, point_session: Path) -> Path:
    """``point_session`` run as it is and with ``--min-parallax 5``, which warns its trial 2
    (ray parallax 1.96 deg, error 1.75 in) out of the statistics."""
    folder = tmp_path_factory.mktemp("parallax")
    for name, extra in (("base", []), ("warned", ["--min-parallax", "5"])):
        args = ["run", str(point_session), "--out", str(folder / name), "--no-scene", *extra]
        result = runner.invoke(app, args)
        assert result.exit_code == 0, result.output
    return folder


def test_a_trial_left_out_of_the_statistics_is_a_regression(parallax_runs: Path) -> None:
    """Before: the warned trial left the statistics (RMSE 1.24 -> 0.06 in, n_used 2 -> 1)
    and ``check`` said ``no regression``, exit 0."""
    warned, base = parallax_runs / "warned", parallax_runs / "base"
    result = runner.invoke(app, ["check", str(warned), "--baseline", str(base)])
    assert result.exit_code == 1, result.output
    line = next(x for x in result.output.splitlines() if "n_used" in x)
    assert line.startswith("REGRESSED point.mcap (point) n_used: 2 -> 1 trials")
    assert "left out of this run's statistics, used by the baseline's: trial 2 (" in line
    assert "parallax 1.96 deg < 5" in line
    assert "REGRESSED point.mcap (point) n_warned: 0 -> 1 trials" in result.output
    # The other way round, the run uses a trial the baseline left out: better, not a failure.
    back = runner.invoke(app, ["check", str(base), "--baseline", str(warned)])
    assert back.exit_code == 1  # (its RMSE rose with the trial back in: that regressed)
    assert "n_used" not in back.output
    assert "n_warned" not in back.output
    # A run without its trials.csv (or one that does not hold the summary's trials): the
    # counts are compared, never nothing.
    bare = base.parent / "bare"
    shutil.copytree(warned, bare)
    trials = pd.read_csv(bare / "trials.csv")
    trials[trials["trial"] != 1].to_csv(bare / "trials.csv", index=False)
    counted = runner.invoke(app, ["check", str(bare), "--baseline", str(base)])
    assert "REGRESSED point.mcap (point) n_used: 2 -> 1 trials" in counted.output
    assert "used by the baseline's" not in counted.output  # no trial named: only counts
    # A tolerance that allows one trial left out lets it pass, said as worse.
    tolerance = base.parent / "one_trial.toml"
    tolerance.write_text("[n_used]\nabsolute = 1\n[n_warned]\nabsolute = 1\n")
    allowed = runner.invoke(
        app, ["check", str(warned), "--baseline", str(base), "--tolerance", str(tolerance)]
    )
    assert allowed.exit_code == 0, allowed.output
    assert "worse point.mcap (point) n_used: 2 -> 1 trials" in allowed.output


def test_a_trial_swapped_for_another_is_seen_by_the_trials(
    parallax_runs: Path, tmp_path: Path
) -> None:
    """Counts alone miss a swap: the baseline left trial 1 out and used trial 2, the run the
    other way round (n_used 1 -> 1): trial 2 left out is a regression all the same."""
    base, run = (
        _copy(parallax_runs / "warned", tmp_path / "b"),
        _copy(parallax_runs / "warned", tmp_path / "r"),
    )
    trials = pd.read_csv(base / "trials.csv", keep_default_na=False)
    warning = trials.loc[trials["trial"] == 2, "warning"].iloc[0]
    trials["warning"] = ["ray parallax 4.00 deg < 5" if t == 1 else "" for t in trials["trial"]]
    trials.to_csv(base / "trials.csv", index=False)
    result = runner.invoke(app, ["check", str(run), "--baseline", str(base)])
    assert "n_used: 1 -> 1 trials" in result.output, result.output
    assert f"trial 2 ({warning})" in result.output
    assert result.exit_code == 1


def _in_metres(folder: Path) -> None:
    """A run's summary.csv as the same run in metres would write it."""
    from analysis.tables.columns import SUMMARY_DOMAINS
    from twopose.values.units import unit_factor

    summary = pd.read_csv(folder / "summary.csv")
    for column, domain in SUMMARY_DOMAINS.items():
        if domain in ("length", "signed") and column in summary:
            summary[column] = summary[column] * unit_factor("in", "m")
    summary["units"] = "m"
    summary.to_csv(folder / "summary.csv", index=False)


def test_an_absolute_allowance_carries_its_unit_into_a_metre_session(
    baseline: Path, tmp_path: Path
) -> None:
    """Before: the default |bias| allowance, 0.05, was read in the session's units, 5 cm in
    a metre session: a 4.3 cm bias change was only "worse", exit 0."""
    base, run = _copy(baseline, tmp_path / "b"), _copy(baseline, tmp_path / "r")
    for folder in (base, run):
        _in_metres(folder)
    summary = pd.read_csv(run / "summary.csv")
    summary.loc[summary["method"] == "point", "bias_z"] += 0.043
    summary.to_csv(run / "summary.csv", index=False)
    result = runner.invoke(app, ["check", str(run), "--baseline", str(base)])
    assert result.exit_code == 1, result.output
    line = next(x for x in result.output.splitlines() if "|bias_z|" in x)
    assert line.startswith("REGRESSED point.mcap (point) |bias_z|")
    rows = check(run, base).comparisons
    point = rows[(rows["method"] == "point") & rows["metric"].str.startswith("|bias_")]
    assert len(point) == 3
    for _, row in point.iterrows():  # 0.05 in, converted, or 10% of the baseline's
        expected = max(0.05 * 0.0254, 0.1 * float(row["baseline"]))
        assert float(row["allowed"]) == pytest.approx(expected)
        assert row["unit"] == "m"
    # A file states its unit; the same 4 cm in centimetres passes.
    tolerance = tmp_path / "cm.toml"
    tolerance.write_text('units = "cm"\n[bias]\nabsolute = 5\n')
    loose = runner.invoke(
        app, ["check", str(run), "--baseline", str(base), "--tolerance", str(tolerance)]
    )
    assert loose.exit_code == 0, loose.output
    assert "allowed 0.05 m)" in loose.output


@pytest.mark.parametrize(
    ("text", "said"),
    [
        (
            "[rmse]\nabsolute = 0.01\n",
            'rmse.absolute = 0.01 is a length with no unit: add units = "in"',
        ),
        (
            "[methods.ground.bias]\nabsolute = 1\n",
            "methods.ground.bias.absolute = 1 is a length with no unit",
        ),
        ('units = "ft"\n', "units must be one of in, mm, cm, m, got 'ft'"),
        (
            'units = "in"\n[methods.ground]\nunits = "mm"\n',
            "methods.ground.units: the unit is the whole file's",
        ),
    ],
)
def test_a_length_allowance_without_its_unit_is_refused(
    tmp_path: Path, text: str, said: str
) -> None:
    path = tmp_path / "tolerance.toml"
    path.write_text(text)
    with pytest.raises(InputValueError) as caught:
        load_tolerance(path)
    assert said in str(caught.value)


def test_counts_and_shares_need_no_unit(tmp_path: Path) -> None:
    path = tmp_path / "tolerance.toml"
    path.write_text("[n_ok]\nabsolute = 1\n[coverage95]\nabsolute = 0.1\n[rmse]\nrelative = 0.2\n")
    tolerance = load_tolerance(path)[""]
    assert (tolerance.n_ok.absolute, tolerance.coverage95.absolute) == (1, 0.1)
    assert tolerance.units == "in"
