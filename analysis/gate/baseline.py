"""The CI gate: a run's ``summary.csv`` checked against a baseline run's, with tolerances
from a TOML file, and JUnit XML that CI systems display (one test case per session and
method).

A metric *got worse* when it moved the wrong way (RMSE, median error and |bias| up; ok
trials, used trials and the 95% coverage down; warned trials up); it *regressed* when it
got worse by more than its allowance, ``max(absolute, relative * |baseline|)``, a length's
absolute allowance converted from the tolerance's unit to the session's
(:mod:`analysis.gate.tolerance`). What the statistics left out is checked too: a trial the
baseline's statistics used and the run's do not (warned or failed since) is a regression
unless the tolerance allows it, named with why (:mod:`analysis.gate.match`). A session and
method in the baseline but not in the run (a session that failed, a method no longer
measured) has regressed too; one only in the run is new, reported but never a failure.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import pandas as pd

from analysis.gate.match import Pair, match_rows, require_identity, run_trials
from analysis.gate.noise import noise_model_difference
from analysis.gate.settings import SettingsDifference, settings_difference
from analysis.gate.tolerance import (
    CHECKED_METRICS,
    Allowance,
    Metric,
    Tolerance,
    load_tolerance,
)
from analysis.tables.declared import SUMMARY_TABLE
from analysis.tables.read_back import check_results_table, read_results_table
from analysis.tables.row_units import rows_word
from twopose.errors import InputValueError
from twopose.methods.specs import Method
from twopose.values.units import unit_spec

__all__ = [
    "CHECKED_METRICS",
    "COMPARISON_COLUMNS",
    "Allowance",
    "CheckResult",
    "Tolerance",
    "check",
    "check_cases",
    "check_lines",
    "compare_summaries",
    "describe",
    "junit_xml",
    "load_tolerance",
    "run_cases",
]


COMPARISON_COLUMNS = [
    "session",
    "method",
    "metric",
    "baseline",
    "result",
    "change",
    "allowed",
    # the unit of baseline, result, change and allowed: the session's for a length (the
    # run's units), "trials" for a count, "" for a share
    "unit",
    # better, same, worse (within tolerance), regressed, missing, new, unheld (the baseline
    # has no value for the metric: not compared, said in a note)
    "status",
    # the trials behind a count's change, in words (n_used: those the run's statistics
    # left out and the baseline's used; n_warned: those warned now and not before)
    "trials",
]


@dataclass(frozen=True, kw_only=True)
class CheckResult:
    """Every comparison (``COMPARISON_COLUMNS``), whether any regressed, and ``notes`` on
    what was not compared (a metric the baseline predates)."""

    comparisons: pd.DataFrame
    notes: tuple[str, ...] = ()
    #: The run and the baseline were computed with different settings (the notes say which).
    settings_differ: bool = False

    @property
    def regressed(self) -> bool:
        return bool(self.comparisons["status"].isin(["regressed", "missing"]).any())

    def worse(self) -> pd.DataFrame:
        """What got worse, regressions first."""
        bad = self.comparisons[self.comparisons["status"].isin(["regressed", "missing", "worse"])]
        order = bad["status"].map({"missing": 0, "regressed": 1, "worse": 2})
        return bad.assign(_o=order).sort_values(["_o", "session", "method"]).drop(columns="_o")


#: Checked columns a baseline may predate (summary.csv gained them later): not compared, with
#: a note. Every other checked column missing from either table is an error.
BASELINE_MAY_LACK = ("coverage95",)
_CHECKED_COLUMNS = tuple(dict.fromkeys(m.column for m in CHECKED_METRICS))


def check(
    results_dir: str | Path, baseline_dir: str | Path, tolerance: str | Path | None = None
) -> CheckResult:
    """``twopose-analyze check``: a run's ``summary.csv`` against a baseline run's.

    Both tables are checked first (:func:`analysis.batch.outputs.read_results_table`: one row
    per session and method, numbers where numbers belong).

    Parameters
    ----------
    results_dir : path-like
        The run folder checked (its ``summary.csv``).
    baseline_dir : path-like
        The baseline run folder.
    tolerance : path-like, optional
        A tolerance TOML (how much worse each metric may get); default: the built-in ones.

    Returns
    -------
    CheckResult
        Every comparison with its status (``regressed``, ``missing``, ``new``, ...).
    """
    tolerances = load_tolerance(tolerance)
    result, baseline = (
        read_results_table(folder, "summary.csv", numeric=_CHECKED_COLUMNS)
        for folder in (results_dir, baseline_dir)
    )
    return compare_summaries(
        result,
        baseline,
        tolerances,
        names=(str(results_dir), str(baseline_dir)),
        trials=(run_trials(results_dir), run_trials(baseline_dir)),
        settings=settings_difference(results_dir, baseline_dir),
    )


def compare_summaries(
    result: pd.DataFrame,
    baseline: pd.DataFrame,
    tolerances: dict[str, Tolerance],
    *,
    names: tuple[str, str] = ("the run", "the baseline"),
    trials: tuple[pd.DataFrame | None, pd.DataFrame | None] = (None, None),
    settings: SettingsDifference | None = None,
) -> CheckResult:
    """Each session and method and checked metric of ``baseline`` against ``result``.

    Sessions are matched by identity, never by path (:mod:`analysis.gate.match`: a session
    whose trials differ between the runs is compared over the trials both hold, from
    ``trials``, the two runs' ``trials.csv``; a baseline in other units is converted). A
    checked column missing from either is an error, but for one the baseline predates
    (:data:`BASELINE_MAY_LACK`): that metric is not compared, and a note says so.
    ``settings``: how the two runs' settings differ (:mod:`analysis.gate.settings`), said
    first; a metric they shape is not compared.
    """
    settings = settings or SettingsDifference()
    for table, name in zip((result, baseline), names, strict=True):
        check_results_table(
            table, f"{name}/summary.csv", numeric=_CHECKED_COLUMNS, columns=SUMMARY_TABLE
        )
    skipped = [c for c in BASELINE_MAY_LACK if c not in baseline.columns]
    for table, name, fix in (
        (baseline, names[1], "replace the baseline with a summary.csv of this twopose"),
        (result, names[0], "run `twopose-analyze run` with this twopose to write it"),
    ):
        require_identity(table, f"{name}/summary.csv", fix)
        lacking = [c for c in _CHECKED_COLUMNS if c not in table.columns and c not in skipped]
        if lacking:
            raise InputValueError(
                f"{name}/summary.csv has no column {', '.join(lacking)}: cannot check it; {fix}"
            )
    notes: tuple[str, ...] = settings.notes + tuple(
        f"not compared: {c} (the baseline predates it; replace the baseline to check it)"
        for c in skipped
    )
    skipped += [c for c in settings.apart if c not in skipped]
    rows: list[dict[str, Any]] = []
    for pair in match_rows(result, baseline, trials, names=names):
        said, apart = noise_model_difference(pair)  # regions of other noise: not compared
        notes += pair.notes + said
        rows += _pair_rows(pair, tolerances, [*skipped, *apart])
    table = pd.DataFrame(rows, columns=COMPARISON_COLUMNS)
    unheld = table[table["status"] == "unheld"]
    notes += tuple(
        f"not compared: {r['metric']} of {r['session']} ({r['method']}): the baseline has no "
        "value for it, so any value passes; replace the baseline to check it"
        for _, r in unheld.iterrows()
    )
    return CheckResult(
        comparisons=table, notes=tuple(dict.fromkeys(notes)), settings_differ=settings.differ
    )


def _pair_rows(
    pair: Pair, tolerances: dict[str, Tolerance], skipped: list[str]
) -> list[dict[str, Any]]:
    """One session and method's comparison rows: its metrics, or why it has none."""
    session, method = pair.session, pair.method
    if pair.baseline is None or pair.result is None:
        status = "missing" if pair.result is None else "new"
        if pair.baseline is None and pair.result is None:  # no trial both runs hold
            status = "missing"
        return [_row(session, method, "(session and method)", math.nan, math.nan, status)]
    rows = []
    kind = pair.result  # its rows: trials; a two-camera session's touches
    if pair.lost:
        lost = _row(session, method, "(trials)", float(pair.lost), math.nan, "missing")
        rows.append(lost | {"unit": rows_word(kind, "maybe_plural")})
    tolerance = tolerances.get(method, tolerances[""])
    units = unit_spec(str(pair.result["units"])).units
    for metric in CHECKED_METRICS:
        if metric.column in skipped:
            continue
        before, after = _value(pair.baseline, metric.column), _value(pair.result, metric.column)
        allowed = tolerance.allowed(metric, before, units)
        # A count of trials is held to the trials behind it, when both runs' are known: a
        # trial the baseline used and the run left out is worse even if another came in.
        trials = _trials_changed(pair, metric)
        worsening = None if trials is None else float(len(trials))
        status = _status(before, after, metric.sign, allowed, worsening)
        said = f"{metric.trials_said}: {'; '.join(trials)}" if trials else ""
        rows.append(
            _row(session, method, metric.name, before, after, status, allowed)
            | {"unit": metric.unit(units, rows_word(kind)), "trials": said}
        )
    return rows


def _trials_changed(pair: Pair, metric: Metric) -> tuple[str, ...] | None:
    """The trials behind a count's change (its :class:`analysis.gate.match.TrialChanges`
    field), or None for a metric that is no such count or a pair whose trials are not
    known."""
    if pair.changes is None or not metric.trials:
        return None
    changed: tuple[str, ...] = getattr(pair.changes, metric.trials)
    return changed


def _value(row: pd.Series, column: str) -> float:
    number = float(pd.to_numeric(row[column], errors="coerce"))
    return abs(number) if column.startswith("bias_") else number


def _status(
    before: float, after: float, sign: int, allowed: float, worsening: float | None = None
) -> str:
    """``worsening``: how much worse, when known apart from the two values (a count's
    trials); else ``sign * (after - before)``."""
    if math.isnan(before):  # the baseline measured nothing: nothing to hold the run to
        return "same" if math.isnan(after) else "unheld"
    if math.isnan(after):
        return "regressed"  # measured before, not now
    change = sign * (after - before)
    if worsening is None:
        worsening = change
    elif worsening == 0:  # no trial lost its use: better when the count says so, else same
        worsening = min(change, 0.0)
    if worsening > allowed + 1e-12:
        return "regressed"
    if worsening > 1e-12:
        return "worse"
    return "better" if worsening < -1e-12 else "same"


def _row(
    session: str,
    method: Method,
    metric: str,
    before: float,
    after: float,
    status: str,
    allowed: float = math.nan,
) -> dict[str, Any]:
    return {
        "session": session,
        "method": method,
        "metric": metric,
        "baseline": before,
        "result": after,
        "change": after - before,
        "allowed": allowed,
        "unit": "",
        "status": status,
        "trials": "",
    }


def describe(row: pd.Series) -> str:
    """One line of what got worse: ``session (method) metric: a -> b unit (+d unit, +p%;
    allowed e unit)``, and the trials behind a count's change."""
    where = f"{row['session']} ({row['method']})"
    if row["status"] == "missing" and row["metric"] == "(trials)":
        return (
            f"REGRESSED {where}: {int(row['baseline'])} {row.get('unit') or 'trial(s)'} of the "
            "baseline not in this "
            "run (a part not read, or a session that failed)"
        )
    if row["status"] == "missing":
        return f"REGRESSED {where}: in the baseline, not in this run (failed or not measured)"
    before, after = float(row["baseline"]), float(row["result"])
    if math.isnan(after):
        return f"REGRESSED {where} {row['metric']}: {before:.4g} -> not measured"
    change = after - before
    share = f", {change / abs(before):+.0%}" if before else ""
    tag = "REGRESSED" if row["status"] == "regressed" else "worse"
    unit = f" {row['unit']}" if str(row.get("unit", "") or "") else ""
    line = (
        f"{tag} {where} {row['metric']}: {before:.4g} -> {after:.4g}{unit} "
        f"({change:+.4g}{unit}{share}; allowed {float(row['allowed']):.4g}{unit})"
    )
    trials = str(row.get("trials", "") or "")
    return f"{line}; {trials}" if trials else line


def check_lines(outcome: CheckResult, baseline: str | Path) -> list[str]:
    """What ``check`` prints: notes, what got worse (regressions first), what is new, and
    one line of verdict."""
    table = outcome.comparisons
    worse = outcome.worse()
    lines = [f"note: {note}" for note in outcome.notes]
    lines += [describe(row) for _, row in worse.iterrows()]
    lines += [
        f"new: {row['session']} ({row['method']}): not in the baseline"
        for _, row in table[table["status"] == "new"].iterrows()
    ]
    compared = table[table["status"] != "new"]  # a new one is said, not checked
    n_pairs = len(compared[["session", "method"]].drop_duplicates())
    n_bad = int(worse["status"].isin(["regressed", "missing"]).sum())
    verdict = f"{n_bad} regression(s)" if n_bad else "no regression"
    if outcome.settings_differ:
        verdict += " (across different settings: see the notes)"
    return [*lines, f"checked {n_pairs} session/method pair(s) against {baseline}: {verdict}"]


def check_cases(result: CheckResult) -> list[tuple[str, str, str | None]]:
    """JUnit cases of a check: (session, method, failure message or None)."""
    cases = []
    for (session, method), g in result.comparisons.groupby(["session", "method"], sort=True):
        bad = g[g["status"].isin(["regressed", "missing"])]
        message = "; ".join(describe(r) for _, r in bad.iterrows()) if len(bad) else None
        cases.append((str(session), str(method), message))
    return cases


def run_cases(summary: pd.DataFrame, errors: pd.DataFrame) -> list[tuple[str, str, str | None]]:
    """JUnit cases of a run: each session and method analysed, each input that failed."""
    cases: list[tuple[str, str, str | None]] = [
        (str(r["session"]), str(r["method"]), None) for _, r in summary.iterrows()
    ]
    cases += [(str(e["session"]), "(session)", str(e["error"])) for _, e in errors.iterrows()]
    return cases


def junit_xml(
    suite: str, cases: list[tuple[str, str, str | None]], notes: Sequence[str] = ()
) -> bytes:
    """JUnit XML (the schema Jenkins, GitLab and GitHub reporters read): one ``testcase``
    per (session, method) with ``classname`` the method, failing with ``message``; the
    ``notes`` (what the run or check said of its inputs: copies, forks, empty and board
    sessions, conversions) as the suite's ``system-out``, which the reporters show."""
    failures = sum(message is not None for _, _, message in cases)
    root = ET.Element("testsuites", name=suite, tests=str(len(cases)), failures=str(failures))
    node = ET.SubElement(
        root, "testsuite", name=suite, tests=str(len(cases)), failures=str(failures), errors="0"
    )
    for session, method, message in cases:
        case = ET.SubElement(node, "testcase", classname=f"twopose.{method}", name=session)
        if message is not None:
            failure = ET.SubElement(case, "failure", message=message[:500])
            failure.text = message
    if notes:
        ET.SubElement(node, "system-out").text = "\n".join(f"note: {n}" for n in notes)
    ET.indent(root)
    body: bytes = ET.tostring(root, encoding="utf-8", xml_declaration=True)
    return body + b"\n"
