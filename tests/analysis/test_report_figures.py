"""Issue 47: a run draws no matplotlib figure unless asked; report.html carries its charts
as Vega-Lite specs with their data and the scripts that draw them; ``run --figures FORMAT``
writes the static figures (PNG through the drawer and its cache, SVG or PDF drawn here)."""

from __future__ import annotations

import json
import re
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from analysis.batch.runner import run
from analysis.cli import app
from analysis.report.charts import session_chart
from analysis.report.html import CHART_SCRIPTS

REPO = Path(__file__).resolve().parents[2]


def _specs(page: str) -> list[dict[str, object]]:
    found = re.findall(r"<script type='application/json' class='chart-spec'>(.*?)</script>", page)
    return [json.loads(s) for s in found]


@pytest.mark.slow  # a whole run (tables, report) of one session: ~3 s
def test_a_default_run_draws_no_figure_and_its_report_carries_its_charts_and_scripts(
    tmp_path: Path, point_session: Path
) -> None:
    out = tmp_path / "out"
    result = run([point_session], out, scene=False)
    assert not [p.name for p in out.iterdir() if p.suffix in (".png", ".svg", ".pdf")]
    assert not (out / "figures.json").exists()
    assert all(not s.images for s in result.sessions)  # the batch drew nothing either
    page = (out / "report.html").read_text()
    assert "<img" not in re.sub(r"<script>.*?</script>", "", page, flags=re.S)
    for script in CHART_SCRIPTS:  # inline: the page opens offline, from a file
        assert f"src='{script}'" not in page
    assert page.count("<script>") == 1 + len(CHART_SCRIPTS) + 1
    specs = _specs(page)
    assert len(specs) == 3  # the overview, sensitivity, the session
    session = specs[-1]
    trials = pd.read_csv(out / "trials.csv")
    ok = trials[trials["status"] == "ok"]
    rows = session["datasets"]["trials"]  # type: ignore[index]
    assert sorted(r["trial"] for r in rows) == sorted(ok["trial"])  # the run's own table
    assert {r["session_name"] for r in rows} == {point_session.name}


@pytest.mark.slow  # three runs drawing every static figure: ~12 s
def test_figures_png_writes_the_static_figures_and_svg_writes_them_as_svg(
    tmp_path: Path, point_session: Path
) -> None:
    cli = CliRunner()
    for fmt in ("png", "svg"):
        out = tmp_path / fmt
        done = cli.invoke(app, ["run", str(point_session), "--out", str(out), "--no-scene",
                                "--figures", fmt])  # fmt: skip
        assert done.exit_code == 0, done.output
        drawn = sorted(p.name for p in out.glob(f"*.{fmt}"))
        assert "error_histogram." + fmt in drawn
        assert any(name.startswith("scatter_00_") for name in drawn), drawn
        assert "sensitivity." + fmt in drawn
        assert (out / "figures.json").exists() == (fmt == "png")
    assert (tmp_path / "svg" / "sensitivity.svg").read_text().lstrip().startswith("<?xml")
    refused = cli.invoke(app, ["run", str(point_session), "--out", str(tmp_path / "x"),
                               "--figures", "gif"])  # fmt: skip
    assert refused.exit_code != 0
    assert "gif" in refused.output
    assert "png, svg, pdf" in refused.output
    both = tmp_path / "both"  # repeated: every format asked, each once
    formats = ["--figures", "pdf", "--figures", "png", "--figures", "pdf"]
    done = cli.invoke(app, ["run", str(point_session), "--out", str(both), "--no-scene",
                            *formats])  # fmt: skip
    assert done.exit_code == 0, done.output
    assert {p.suffix for p in both.glob("error_histogram.*")} == {".png", ".pdf"}
    assert (both / "error_histogram.pdf").read_bytes().startswith(b"%PDF")


@pytest.mark.slow  # analyses a session (1-3 s)
def test_a_sessions_chart_frames_by_the_used_trials_and_draws_an_outlier_at_the_edge(
    point_session: Path,
) -> None:
    """Honesty: a warned trial far away never sets the axes; it is drawn at the frame's
    edge and its tooltip keeps its real error."""
    from analysis.session.pipeline import analyse_session

    s = analyse_session(point_session)
    trials = s.trials.copy()
    far = trials.index[0]
    trials.loc[far, "err_x"] = 1000.0
    trials.loc[far, "warning"] = "near-degenerate"
    spec = session_chart(s.name, trials, s.averaging, s.views, unit_text="in")
    assert spec is not None
    scatter = spec["concat"][0]
    points = scatter["layer"][-1]["encoding"]
    assert points["x"]["scale"]["domain"][1] < 1000.0
    [row] = [r for r in spec["datasets"]["trials"] if r["err_x"] == 1000.0]
    assert row["sx"] == points["x"]["scale"]["domain"][1]
    assert row["shown"] == "beyond the frame, at its edge"
    titles = [points["x"]["title"], points["y"]["title"]]
    assert titles == ["x error (in)", "z error (in)"]


@pytest.mark.slow  # analyses a session (1-3 s)
def test_the_answer_comes_before_the_list_of_failed_inputs_which_one_line_counts(
    point_session: Path,
) -> None:
    import dataclasses

    from analysis.report.writer import _report_html

    result = run([point_session])
    failed = pd.DataFrame([{"session": "bad.mcap", "error": "bad.mcap: not a session"}])
    result = dataclasses.replace(
        result,
        errors=failed,
        input_notes=("copy.mcap: a copy", "b.mcap: continues a.mcap; one session with a.mcap"),
        inputs_set_aside=("copy.mcap",),  # what the line counts: not the continuation
    )
    sweep = {"method": "point", "sweep": "pixel noise", "value": 0.1, "unit": "px", "rmse": 0.03}
    page = _report_html(result, pd.DataFrame([sweep | {"n_ok": 10}]))
    line = page.index("class='inputs-line")
    assert "1 input(s) failed and 1 not analysed as given" in page
    assert line < page.index("id='answer'") < page.index("id='inputs'")
    assert page.index("href='#inputs'") < page.index("id='answer'")


@pytest.mark.slow  # a fresh interpreter analyses a sample session (~4 s)
def test_a_run_that_draws_no_figure_never_imports_matplotlib(tmp_path: Path) -> None:
    """Issue 47: a run's fixed cost (a re-run's most of all) carries no figure library
    unless ``--figures`` asks for static images; the charts are the browser's."""
    import subprocess
    import sys

    code = (
        "import sys, analysis; "
        f"analysis.run([{str(REPO / 'sessions' / 'thesis_line.mcap')!r}], "
        f"{str(tmp_path / 'out')!r}, scene=False); "
        "print('matplotlib' in sys.modules)"
    )
    done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          cwd=REPO, check=True)  # fmt: skip
    assert done.stdout.strip().splitlines()[-1] == "False", done.stdout + done.stderr


def test_the_method_colours_are_matplotlibs_without_matplotlib() -> None:
    from matplotlib.colors import to_hex

    from analysis.report.run_charts import hex_colour

    assert [hex_colour(f"C{i}") for i in range(10)] == [to_hex(f"C{i}") for i in range(10)]


@pytest.mark.slow  # analyses two sample sessions (about 3 s)
def test_the_histogram_has_a_panel_per_session_set_as_the_static_figure() -> None:
    """With thesis_ and stress_ sessions the browser's histogram is one panel per set (its
    rows), as the static figure's; with one set, one panel."""
    from analysis.report.run_charts import overview_charts

    names = ("thesis_line.mcap", "stress_line.mcap")
    result = run([str(REPO / "sessions" / n) for n in names], None)
    both = overview_charts(result.trials)
    assert both is not None
    histogram = both["concat"][0]
    assert histogram["encoding"]["row"]["field"] == "set"
    assert {r["set"] for r in both["data"]["values"]} == {"thesis", "stress"}
    one = overview_charts(result.trials[result.trials["session"].str.contains("thesis_")])
    assert one is not None
    assert "row" not in one["concat"][0]["encoding"]


@pytest.mark.slow  # two runs drawing a session's SVG and PDF figures in fresh interpreters
def test_the_static_figures_are_the_same_bytes_every_run(tmp_path: Path) -> None:
    """No creation date, no random SVG ids, no drawing order from a set's hash order
    (thesis_line has left-out trials beyond the frame on two sides): two runs under other
    hash seeds write the same SVG and PDF files, as their tables."""
    import os
    import subprocess
    import sys

    session = str(REPO / "sessions" / "thesis_line.mcap")
    for seed in ("1", "2"):
        code = (
            "import analysis; "
            f"analysis.run([{session!r}], {str(tmp_path / seed)!r}, scene=False, "
            "options=analysis.AnalysisOptions(figures=('svg', 'pdf')))"
        )
        env = {**os.environ, "PYTHONHASHSEED": seed}
        subprocess.run([sys.executable, "-c", code], cwd=REPO, env=env, check=True)
    drawn = sorted(p.name for p in (tmp_path / "1").iterdir() if p.suffix in (".svg", ".pdf"))
    assert "averaging_00_thesis_line.svg" in drawn
    assert len(drawn) == 14, drawn  # 3 of the session, 4 of the run, in each format
    for name in drawn:
        assert (tmp_path / "1" / name).read_bytes() == (tmp_path / "2" / name).read_bytes(), name
