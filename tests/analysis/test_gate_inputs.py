"""``check`` and ``compare`` on the inputs a careless analyst produces (issue 22): a
session and method twice, a misspelt method in a tolerance file, a missing column, a
baseline older than ``coverage95``; then hypothesis over tolerance files and over
``summary.csv`` / ``trials.csv`` shapes (columns and rows missing, doubled, extra). Each
ends in exit 0, 1 or 3 with a message, never a traceback, and never a pass on a run that
got worse."""

from __future__ import annotations

import csv
import json
import math
import shutil
import tempfile
from pathlib import Path
from typing import Any

import pandas as pd
import pytest
from hypothesis import HealthCheck, assume, given, settings
from hypothesis import strategies as st
from typer.testing import CliRunner

from analysis.cli import app
from tests.fuzzing import Outcomes, check_command

runner = CliRunner()
Table = tuple[list[str], list[list[str]]]  # a CSV file: header and rows, as text


@pytest.fixture(scope="module")
def run_dir(
    tmp_path_factory: pytest.TempPathFactory, point_session: Path, ground_session: Path
) -> Path:
    out = tmp_path_factory.mktemp("gate_inputs") / "run"
    args = ["run", str(point_session), str(ground_session), "--out", str(out), "--no-scene"]
    result = runner.invoke(app, args)
    assert result.exit_code == 0, result.output
    return out


def _read(path: Path) -> Table:
    with open(path, newline="", encoding="utf-8") as fh:
        header, *rows = list(csv.reader(fh))
    return header, rows


def _write(folder: Path, name: str, table: Table) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    with open(folder / name, "w", newline="", encoding="utf-8") as fh:
        csv.writer(fh).writerows([table[0], *table[1]])
    return folder


def _scaled(table: Table, method: str, column: str, factor: float) -> Table:
    header, rows = table
    i, m = header.index(column), header.index("method")
    return header, [
        [*r[:i], repr(float(r[i]) * factor), *r[i + 1 :]] if r[m] == method else list(r)
        for r in rows
    ]


def _check(args: list[str]) -> tuple[int, str]:
    outcomes = Outcomes()
    code = check_command(app, args, " ".join(args), outcomes)
    assert outcomes.violations == [], outcomes.violations  # a traceback, a hang, silence
    assert code is not None
    return code, runner.invoke(app, args).output


# -- What we saw: the CI gate passes regressions ---------------------------------------


@pytest.mark.parametrize("side", ["run", "baseline"])
def test_a_session_and_method_twice_is_an_error_naming_them(
    run_dir: Path, tmp_path: Path, side: str
) -> None:
    """Before: only the first of the two rows was checked; a doubled RMSE in the second
    passed with exit 0."""
    summary = _read(run_dir / "summary.csv")
    worse = _scaled(summary, "ground", "rmse", 2.0)
    ground = next(r for r in worse[1] if r[summary[0].index("method")] == "ground")
    doubled = _write(tmp_path / "doubled", "summary.csv", (summary[0], [*summary[1], ground]))
    results, baseline = (doubled, run_dir) if side == "run" else (run_dir, doubled)
    code, output = _check(["check", str(results), "--baseline", str(baseline)])
    assert code == 3
    assert "more than one row for ground.mcap (ground)" in output
    assert "point.mcap" not in output  # the pair given once is not named


def test_a_misspelt_method_in_a_tolerance_file_is_refused(run_dir: Path, tmp_path: Path) -> None:
    """Before: ``[methods.piont.rmse]`` was ignored, so a file meant to hold method 1 to 5%
    let its RMSE rise by half (exit 0)."""
    worse = _write(
        tmp_path / "worse",
        "summary.csv",
        _scaled(_read(run_dir / "summary.csv"), "point", "rmse", 1.5),
    )
    tolerance = tmp_path / "tolerance.toml"
    tolerance.write_text("[rmse]\nrelative = 1.0\n[methods.piont.rmse]\nrelative = 0.05\n")
    args = ["check", str(worse), "--baseline", str(run_dir), "--tolerance", str(tolerance)]
    code, output = _check(args)
    assert code == 3
    assert "unknown method(s) methods.piont; known: ground, line, point" in output
    tolerance.write_text("[rmse]\nrelative = 1.0\n[methods.point.rmse]\nrelative = 0.05\n")
    assert _check(args)[0] == 1  # spelt right, it holds


@pytest.mark.parametrize(
    ("text", "named"),
    [
        ("oops = 1\n", "unknown key(s) oops; known here: bias, coverage95"),
        ("[rmse]\nrelatve = 0.2\n", "unknown key(s) rmse.relatve; known here: absolute"),
        ("[methods.ground.rmse]\nrelatve = 0.2\n", "methods.ground: unknown key(s) rmse.relatve"),
        ("[methods.ground]\nrmsee = {relative = 1}\n", "unknown key(s) rmsee; known here: bias"),
        ('[methods.""]\n', "unknown method(s) methods.; known: ground, line, point"),
        ("[methods]\nLINE = {}\n", "unknown method(s) methods.LINE"),
        ("methods = 3\n", "methods must be a table"),
        ("[methods.line]\nrmse = 0.5\n", "methods.line: rmse must be a table"),
        ("[methods.line.bias]\nabsolute = -1\n", "methods.line.bias.absolute is -1"),
        ("[bias]\nabsolute = nan\n", "bias.absolute: 'nan' is not a number"),
        ("[bias]\nabsolute = true\n", "bias.absolute must be a finite number"),
    ],
)
def test_unknown_keys_anywhere_in_a_tolerance_file_are_refused_by_name(
    run_dir: Path, tmp_path: Path, text: str, named: str
) -> None:
    tolerance = tmp_path / "tolerance.toml"
    tolerance.write_text(text)
    code, output = _check(
        ["check", str(run_dir), "--baseline", str(run_dir), "--tolerance", str(tolerance)]
    )
    assert code == 3
    assert named in output.replace("\n", " ")


def test_a_tolerance_that_is_not_a_file_is_refused_not_read(run_dir: Path, tmp_path: Path) -> None:
    import os

    fifo = tmp_path / "tolerance.toml"
    os.mkfifo(fifo)  # reading it would wait forever
    code, output = _check(
        ["check", str(run_dir), "--baseline", str(run_dir), "--tolerance", str(fifo)]
    )
    assert code == 3
    assert "not a file" in output


def test_a_baseline_before_coverage95_is_checked_without_it_and_says_so(
    run_dir: Path, tmp_path: Path
) -> None:
    """Before: a KeyError traceback."""
    old = pd.read_csv(run_dir / "summary.csv").drop(columns=["coverage95"])
    baseline = tmp_path / "old"
    baseline.mkdir()
    old.to_csv(baseline / "summary.csv", index=False)
    code, output = _check(["check", str(run_dir), "--baseline", str(baseline)])
    assert code == 0
    assert "note: not compared: coverage95 (the baseline predates it" in output
    worse = _write(
        tmp_path / "worse",
        "summary.csv",
        _scaled(_read(run_dir / "summary.csv"), "ground", "rmse", 1.5),
    )
    code, output = _check(["check", str(worse), "--baseline", str(baseline)])
    assert code == 1  # the other metrics are still checked
    assert "REGRESSED ground.mcap (ground) rmse" in output


CHECKED = ["rmse", "median_err", "bias_x", "bias_y", "bias_z", "n_ok", "coverage95"]


@pytest.mark.parametrize("column", ["session", "method", *CHECKED])
@pytest.mark.parametrize("side", ["run", "baseline"])
def test_a_missing_column_is_a_message_not_a_traceback(
    run_dir: Path, tmp_path: Path, column: str, side: str
) -> None:
    """Before: a KeyError traceback for every checked column."""
    lacking = tmp_path / "lacking"
    lacking.mkdir()
    pd.read_csv(run_dir / "summary.csv").drop(columns=[column]).to_csv(
        lacking / "summary.csv", index=False
    )
    results, baseline = (lacking, run_dir) if side == "run" else (run_dir, lacking)
    code, output = _check(["check", str(results), "--baseline", str(baseline)])
    if side == "baseline" and column == "coverage95":
        assert code == 0
        assert "not compared: coverage95" in output
    else:
        assert code == 3
        assert f"no column {column}" in output


@pytest.mark.parametrize("column", ["gt_x", "status", "trial", "units", "session", "x"])
def test_compare_with_a_column_missing_from_trials_is_a_message(
    run_dir: Path, tmp_path: Path, column: str
) -> None:
    """Before: a KeyError traceback (gt_x, status, trial, units)."""
    lacking = tmp_path / "lacking"
    lacking.mkdir()
    pd.read_csv(run_dir / "trials.csv").drop(columns=[column]).to_csv(
        lacking / "trials.csv", index=False
    )
    code, output = _check(["compare", str(lacking), str(run_dir), "--out", str(tmp_path / "c")])
    assert code == 3
    assert "/trials.csv has no" in output
    assert column in output
    assert not (tmp_path / "c").exists()


def test_compare_refuses_a_trial_given_twice_naming_it(run_dir: Path, tmp_path: Path) -> None:
    """Before: the last of the two rows was kept without a word."""
    header, rows = _read(run_dir / "trials.csv")
    doubled = _write(tmp_path / "doubled", "trials.csv", (header, [*rows, rows[0]]))
    code, output = _check(["compare", str(doubled), str(run_dir), "--out", str(tmp_path / "c")])
    assert code == 3
    session = Path(rows[0][header.index("session")]).name
    trial = rows[0][header.index("trial")]
    assert f"more than one row for {session} ({rows[0][header.index('method')]}) trial {trial}" in (
        output
    )


# -- Hypothesis: tolerance files ------------------------------------------------------

METRICS = ["rmse", "median_err", "bias", "n_ok", "coverage95"]
NUMBER = st.one_of(st.floats(min_value=0, max_value=5), st.integers(min_value=0, max_value=10**6))
ALLOWANCE = st.dictionaries(st.sampled_from(["relative", "absolute"]), NUMBER, max_size=2)
TABLE = st.dictionaries(st.sampled_from(METRICS), ALLOWANCE, max_size=3)
#: What a careless hand does to a good file: a misspelt key at any level, a method that
#: does not exist, a number that is no allowance, a value where a table belongs.
DEFECT = st.one_of(
    st.none(),
    st.tuples(st.just("top key"), st.sampled_from(["oops", "rmsee", "method", "Methods"])),
    st.tuples(
        st.just("field"), st.sampled_from(METRICS), st.sampled_from(["relativ", "abs", "sigma"])
    ),
    st.tuples(st.just("method"), st.sampled_from(["piont", "", "Ground", "points", "lines"])),
    st.tuples(
        st.just("number"),
        st.sampled_from(["", "point", "ground"]),
        st.sampled_from(METRICS),
        st.sampled_from(["relative", "absolute"]),
        st.sampled_from([-1, -0.5, -1e-9, math.nan, math.inf, -math.inf, True, "0.1"]),
    ),
    st.tuples(st.just("not a table"), st.sampled_from(["methods", "rmse", "methods.line"])),
)


@st.composite
def tolerance_files(draw: st.DrawFn) -> dict[str, Any]:
    tolerance: dict[str, Any] = draw(TABLE)
    methods: Any = draw(
        st.dictionaries(st.sampled_from(["point", "line", "ground"]), TABLE, max_size=3)
    )
    defect = draw(DEFECT)
    if defect is not None:
        kind, *args = defect
        if kind == "top key":
            tolerance[args[0]] = {}
        elif kind == "field":
            tolerance.setdefault(args[0], {})[args[1]] = 0.1
        elif kind == "method":
            methods[args[0]] = {}
        elif kind == "number":
            where = methods.setdefault(args[0], {}) if args[0] else tolerance
            where.setdefault(args[1], {})[args[2]] = args[3]
        elif args[0] == "methods":
            methods = 3
        elif args[0] == "rmse":
            tolerance["rmse"] = 0.5
        else:
            methods["line"] = "x"
    keep_empty: bool = draw(st.booleans())
    if methods or keep_empty:
        tolerance["methods"] = methods
    units = draw(st.sampled_from([None, "in", "mm", "m"]))
    if units is not None:
        tolerance["units"] = units
    return tolerance


def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float) and not math.isfinite(value):
        return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
    if isinstance(value, int | float):
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    return "{" + ", ".join(f"{json.dumps(k)} = {_toml_value(v)}" for k, v in value.items()) + "}"


def _valid_number(value: Any) -> bool:
    return (
        isinstance(value, int | float)
        and not isinstance(value, bool)
        and math.isfinite(value)
        and value >= 0
    )


LENGTHS = ("rmse", "median_err", "bias")


def _valid_table(table: Any, *, units: bool) -> bool:
    """The rule docs/ci.md states, written out independently of the code: a length's
    absolute allowance other than 0 only in a file that states its ``units``."""
    return isinstance(table, dict) and all(
        k in METRICS
        and isinstance(v, dict)
        and all(
            f in ("relative", "absolute")
            and _valid_number(x)
            and (f != "relative" or x <= 1)
            and (f != "absolute" or k not in LENGTHS or units or x == 0)
            for f, x in v.items()
        )
        for k, v in table.items()
    )


def _ground_rmse(folder: Path) -> float:
    summary = pd.read_csv(folder / "summary.csv")
    return float(summary.loc[summary["method"] == "ground", "rmse"].iloc[0])


#: Inches in one of each unit a generated file states (the run's sessions are in inches).
INCHES = {"in": 1.0, "mm": 1 / 25.4, "m": 1000 / 25.4}


def _ground_rmse_allowance(tolerance: dict[str, Any], baseline_rmse: float) -> float:
    rmse = {"relative": 0.10, "absolute": 0.0}
    rmse |= tolerance.get("rmse", {})
    rmse |= tolerance.get("methods", {}).get("ground", {}).get("rmse", {})
    absolute = float(rmse["absolute"]) * INCHES[tolerance.get("units", "in")]
    return max(absolute, float(rmse["relative"]) * abs(baseline_rmse))


@pytest.mark.slow
@settings(max_examples=80, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(tolerance=tolerance_files(), factor=st.floats(min_value=1.0, max_value=4.0))
def test_generated_tolerance_files_are_refused_or_applied_exactly(
    run_dir: Path, tolerance: dict[str, Any], factor: float
) -> None:
    """A file is refused (3) exactly when it breaks the documented rule; otherwise an
    unchanged run passes, and a worse ground RMSE fails exactly when it got worse by more
    than the allowance the file gives."""
    methods = tolerance.get("methods", {})
    units = "units" in tolerance
    top = {k: v for k, v in tolerance.items() if k not in ("methods", "units")}
    valid = (
        _valid_table(top, units=units)
        and isinstance(methods, dict)
        and all(
            m in ("point", "line", "ground") and _valid_table(t, units=units)
            for m, t in methods.items()
        )
    )
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        path = folder / "tolerance.toml"
        path.write_text("".join(f"{k} = {_toml_value(v)}\n" for k, v in tolerance.items()))
        summary = _read(run_dir / "summary.csv")
        worse = _write(folder / "worse", "summary.csv", _scaled(summary, "ground", "rmse", factor))
        code, output = _check(
            ["check", str(run_dir), "--baseline", str(run_dir), "--tolerance", str(path)]
        )
        assert code == (0 if valid else 3), output
        if not valid:
            return
        before, after = (_ground_rmse(folder) for folder in (run_dir, worse))
        allowed = _ground_rmse_allowance(tolerance, before)
        assume(abs((after - before) - allowed) > 1e-9 * max(1.0, before))
        code, output = _check(
            ["check", str(worse), "--baseline", str(run_dir), "--tolerance", str(path)]
        )
        assert code == (1 if after - before > allowed else 0), output


# -- Hypothesis: summary.csv and trials.csv shapes ------------------------------------

EDITS = st.lists(
    st.one_of(
        st.tuples(st.just("drop column"), st.integers(0, 40)),
        st.tuples(st.just("double column"), st.integers(0, 40)),
        st.tuples(st.just("extra column"), st.sampled_from(["extra", "rmse_new", " rmse"])),
        st.tuples(st.just("drop row"), st.integers(0, 5)),
        st.tuples(st.just("double row"), st.integers(0, 5)),
        st.tuples(st.just("extra row"), st.integers(0, 5)),
        st.tuples(st.just("header again"), st.integers(0, 5)),
        st.tuples(st.just("blank cell"), st.integers(0, 400)),
        st.tuples(st.just("text cell"), st.integers(0, 400)),
    ),
    max_size=3,
)


def _edited(table: Table, edits: list[tuple[str, Any]]) -> Table:
    header, rows = list(table[0]), [list(r) for r in table[1]]
    for edit, arg in edits:
        n = len(header)
        if edit == "drop column" and n > 1:
            i = arg % n
            header.pop(i)
            rows = [r[:i] + r[i + 1 :] for r in rows]
        elif edit == "double column" and n:
            i = arg % n
            header.append(header[i])
            rows = [[*r, r[i] if i < len(r) else ""] for r in rows]
        elif edit == "extra column":
            header.append(arg)
            rows = [[*r, "1.5"] for r in rows]
        elif edit == "drop row" and rows:
            rows.pop(arg % len(rows))
        elif edit == "double row" and rows:
            rows.append(list(rows[arg % len(rows)]))
        elif edit == "extra row" and rows:
            extra = list(rows[arg % len(rows)])
            if "session" in header:
                extra[header.index("session")] = f"/elsewhere/extra{arg}.mcap"
            rows.append(extra)
        elif edit == "header again":  # two tables concatenated
            rows.insert(arg % (len(rows) + 1), list(header))
        elif edit in ("blank cell", "text cell") and rows and n:
            r, c = rows[arg % len(rows)], (arg // 7) % n
            if c < len(r):
                r[c] = "" if edit == "blank cell" else "n/a?"
    return header, rows


def _one_numeric_ground_rmse(table: Table) -> bool:
    """Whether a baseline states one RMSE for the ground session: then a run with a worse
    one has something to be worse than."""
    header, rows = table
    if header.count("rmse") != 1 or header.count("method") != 1 or header.count("session") != 1:
        return False
    m, s, e = header.index("method"), header.index("session"), header.index("rmse")
    ground = [r for r in rows if len(r) == len(header) and r[m] == "ground"]
    if len(ground) != 1 or not ground[0][s].endswith("ground.mcap"):
        return False
    try:
        return math.isfinite(float(ground[0][e]))
    except ValueError:
        return False


@pytest.mark.slow
@settings(max_examples=120, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(run_edits=EDITS, baseline_edits=EDITS, worse=st.booleans())
def test_generated_summaries_exit_0_1_or_3_and_never_pass_a_worse_run(
    run_dir: Path,
    run_edits: list[tuple[str, Any]],
    baseline_edits: list[tuple[str, Any]],
    worse: bool,
) -> None:
    summary = _read(run_dir / "summary.csv")
    result = _scaled(summary, "ground", "rmse", 3.0) if worse else summary
    result, baseline = _edited(result, run_edits), _edited(summary, baseline_edits)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        args = [
            "check",
            str(_write(folder / "run", "summary.csv", result)),
            "--baseline",
            str(_write(folder / "base", "summary.csv", baseline)),
        ]
        code, output = _check(args)
    assert code in (0, 1, 3)
    if worse and _one_numeric_ground_rmse(baseline):
        assert code != 0, (result, baseline, output)  # never a pass on a worse run
    if not run_edits and not baseline_edits:
        assert code == (1 if worse else 0), output


@pytest.mark.slow
@settings(max_examples=40, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(a_edits=EDITS, b_edits=EDITS, estimator=st.sampled_from(["thesis", "optimal"]))
def test_generated_trials_tables_compare_or_are_refused_with_a_message(
    run_dir: Path, a_edits: list[tuple[str, Any]], b_edits: list[tuple[str, Any]], estimator: str
) -> None:
    trials = _read(run_dir / "trials.csv")
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        a = _write(folder / "a", "trials.csv", _edited(trials, a_edits))
        b = _write(folder / "b", "trials.csv", _edited(trials, b_edits))
        shutil.copy(run_dir / "summary.json", b / "summary.json")
        code, output = _check(
            ["compare", str(a), str(b), "--out", str(folder / "c"), "--estimator-a", estimator]
        )
    assert code in (0, 3), output
