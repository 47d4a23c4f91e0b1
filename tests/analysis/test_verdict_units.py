"""Verdicts never pool units silently (issue 43, part 5).

A run over a session in inches and one in centimetres: the verdict lines (terminal and
report) and thesis.csv are in the thesis' inches and say which errors they converted; the
terminal's and the report's "within 1" columns name their unit; the histogram's axis names
its unit and the conversion. A run whose every trial is warned still prints a verdict line
per method, saying that no trial is usable, and its histogram names a real unit.
"""

from __future__ import annotations

import shutil
from pathlib import Path

import pandas as pd
import pytest
from matplotlib.figure import Figure
from typer.testing import CliRunner

from analysis.batch.runner import run
from analysis.cli import app
from analysis.report import thesis as thesis_module
from analysis.report.figures.draw import plot_error_histogram
from analysis.report.terminal import closing_lines
from analysis.report.thesis import thesis_table, thesis_verdict
from analysis.results import AnalysisOptions
from analysis.session.metrics import warned
from recorder.simulate.one_camera import simulate_session
from twopose.methods.specs import Method
from twopose.sim.scene import Scene
from twopose.solve.margins import EstimateOptions
from twopose.values.units import Units


@pytest.fixture(scope="module")
def two_units(tmp_path_factory: pytest.TempPathFactory, point_session: Path) -> Path:
    """A folder of two small point sessions: the suite's in inches, one in centimetres."""
    folder = tmp_path_factory.mktemp("units")
    shutil.copyfile(point_session, folder / "a_in.mcap")
    simulate_session(
        folder / "b_cm.mcap", method=Method.POINT, trials=2, frames=2, seed=2,
        scene=Scene().in_units(Units.CM),
    )  # fmt: skip
    return folder


def _run(folder: Path, out: Path, *options: str) -> list[str]:
    """``twopose-analyze run`` as a pipe prints it (whole lines)."""
    done = CliRunner().invoke(app, ["run", str(folder), "--out", str(out), "--no-scene", *options])
    assert done.exit_code == 0, done.output
    return done.stdout.splitlines()


def _verdicts(lines: list[str]) -> list[str]:
    return [line for line in lines if line.startswith("verdict:")]


def test_a_run_in_two_units_says_what_it_converted(two_units: Path, tmp_path: Path) -> None:
    out = tmp_path / "out"
    lines = _run(two_units, out)
    (verdict,) = _verdicts(lines)
    # Pooled over both sessions in the thesis' inches, and it says so.
    assert "of 4 trials within 1 in (largest" in verdict
    assert "2 of 4 errors converted from cm" in verdict
    # The per-unit tables' share within 1 names its unit: 1 in, then 1 cm.
    headers = [line for line in lines if line.startswith("method ")]
    assert [h.split()[-2:] for h in headers] == [["≤1", "in"], ["≤1", "cm"]]
    session_lines = [line for line in lines if line.startswith("  ")]
    assert any("(point, cm):" in s and "within 1 cm:" in s for s in session_lines)
    assert any("(point, in):" in s and "within 1 in:" in s for s in session_lines)
    # thesis.csv: every row over the trials names its unit and the conversion.
    thesis = pd.read_csv(out / "thesis.csv").set_index("claim")
    method1 = str(thesis.loc["method 1 (fixed point) errors", "twopose"])
    assert "within 1 in" in method1
    assert "2 of 4 errors converted from cm" in method1
    # The report: a table per unit, its "within 1" column naming it; the verdict as printed.
    page = (out / "report.html").read_text(encoding="utf-8")
    assert "<th>within 1 in</th>" in page
    assert "<th>within 1 cm</th>" in page
    assert "within 1 unit" not in page
    assert verdict.removeprefix("verdict: ") in page.replace("&#x27;", "'")


def test_the_histogram_names_its_unit_and_the_conversion() -> None:
    trials = pd.DataFrame(
        {
            "session": ["a.mcap", "a.mcap", "b.mcap", "b.mcap"],
            "trial": [1, 2, 1, 2],
            "method": "point",
            "units": ["in", "in", "cm", "cm"],
            "status": "ok",
            "err": [0.5, 0.7, 1.27, 2.54],
            "warning": "",
        }
    )
    fig = Figure()
    plot_error_histogram(fig, trials)
    label = fig.axes[-1].get_xlabel()
    assert label.startswith("error (in); bins")
    assert label.endswith("; cm converted to in")
    fig = Figure()
    plot_error_histogram(fig, trials.assign(warning="ray parallax 0.5 deg < 1"))
    label = fig.axes[-1].get_xlabel()
    assert "session units" not in label
    assert label.startswith("error (in); bins")


def test_an_all_warned_run_prints_its_verdict(two_units: Path, tmp_path: Path) -> None:
    warn_all = EstimateOptions(min_parallax_deg=89.0)  # --min-parallax 89: every trial warned
    result = run([two_units], options=AnalysisOptions(estimate=warn_all), scene=False)
    assert warned(result.trials).all()
    (verdict,) = closing_lines(result.verdict, tmp_path, width=None)  # no report written
    assert verdict.startswith("verdict: point (method 1): no trial usable: all 4 ok trial(s)")
    assert "warned, left out (--include-warned keeps them)" in verdict
    row = result.thesis.set_index("claim").loc["method 1 (fixed point) errors"]
    assert row["reproduced"] == "no data"
    assert row["twopose"].startswith("no trial usable: all 4 ok trial(s) warned")
    fig = Figure()
    plot_error_histogram(fig, result.trials)
    assert fig.axes[-1].get_xlabel().startswith("error (in); bins")  # not "session units"


def test_each_verdict_says_why_no_trial_is_usable() -> None:
    trials = pd.DataFrame(
        {
            "session": "s.mcap",
            "trial": [1, 2, 3, 4, 5],
            "method": ["point", "point", "ground", "line", "line"],
            "units": "mm",
            "status": ["ok", "ok", "degenerate", "ok", "ok"],
            "err": [3.0, 4.0, float("nan"), float("nan"), float("nan")],
            "err_x": [1.0, 1.0, float("nan"), float("nan"), float("nan")],
            "warning": ["plane angle 1 deg < 5 deg", "plane angle 2 deg < 5 deg", "", "", ""],
        }
    ).assign(gt_x=10.0, gt_y=0.0, gt_z=200.0)
    ground, line, point = thesis_verdict(trials)
    assert ground == (
        "ground (method 2): no trial usable: none of its 1 trial(s) is ok; nothing to set "
        "against the thesis."
    )
    assert line.startswith("line: no trial usable: none of its 2 ok trial(s) has a known error")
    assert line.endswith("the thesis did not test this method.")
    assert point.startswith("point (method 1): no trial usable: all 2 ok trial(s) warned")
    # With the warned trials included: counted, in inches, converted from mm.
    included = thesis_verdict(trials, include_warned=True)[2]
    assert included.startswith("point (method 1): 2 of 2 trials within 1 in (largest 0.16 in)")
    assert ", errors converted from mm;" in included
    table = thesis_table(trials, pd.DataFrame(columns=["session", "trial", "n_frames"]))
    rows = table.set_index("claim")["twopose"]
    assert rows["method 2 overestimates x"] == "no trial usable: none of its 1 trial(s) is ok"


def test_converted_from_names_each_unit_and_its_count() -> None:
    converted_from = thesis_module.converted_from
    assert converted_from(pd.Series(["in", "in"])) == ""
    assert converted_from(pd.Series(["cm", "cm"])) == ", errors converted from cm"
    assert converted_from(pd.Series(["mm", "cm"])) == ", errors converted from cm and mm"
    assert converted_from(pd.Series(["in", "cm", "cm"])) == ", 2 of 3 errors converted from cm"
