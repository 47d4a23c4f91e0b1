"""report: plots that take an Axes, the console summary cells, the dominant-input counts."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.collections import LineCollection, PolyCollection
from matplotlib.figure import Figure

from analysis.report.figures.draw import (
    MAX_LEGEND,
    error_ellipses,
    figure_key,
    make_figures,
    plot_error_scatter,
    png_bytes,
    session_figures,
)
from analysis.report.thesis import _used, _within_row, thesis_verdict
from analysis.report.writer import ANSWER_COLUMNS, answer_table, dominant_inputs
from twopose.methods.specs import Method
from twopose.uncertainty.propagate import CHI2_95


def _trials() -> pd.DataFrame:
    return pd.DataFrame(
        {
            "session": "s.mcap",
            "trial": [1, 2, 3],
            "units": "in",
            "status": ["ok", "ok", "degenerate"],
            "err_x": [0.2, -0.4, 5.0],
            "err_z": [0.1, 0.3, 5.0],
            "err": [0.22, 0.5, 7.1],
            "sigma_x": [0.5, 1.0, np.nan],
            "sigma_z": [0.25, 0.5, np.nan],
            "cov_xz": [0.0, 0.0, np.nan],
            "dominant_input": ["x translation", "pixels", ""],
            "dominant_share": [0.9, 0.6, np.nan],
        }
    )


def test_error_ellipses_have_the_95_percent_size_of_each_covariance() -> None:
    ok = _trials().iloc[:2]
    ellipses = error_ellipses(ok)
    k = np.sqrt(CHI2_95[2])
    # Full axes 2 k sigma: the major one along x (the larger sigma here), the minor along z.
    np.testing.assert_allclose(np.asarray(ellipses.get_widths()), [2 * k * 0.5, 2 * k * 1.0])
    np.testing.assert_allclose(np.asarray(ellipses.get_heights()), [2 * k * 0.25, 2 * k * 0.5])
    np.testing.assert_allclose(
        np.asarray(ellipses.get_offsets()), ok[["err_x", "err_z"]].to_numpy()
    )


def test_error_scatter_draws_ok_trials_on_a_given_axes() -> None:
    fig = Figure()
    ax = fig.add_subplot()
    handles, note = plot_error_scatter(ax, _trials(), "the title")
    assert ax.get_title() == "the title"
    points = np.asarray(ax.collections[1].get_offsets())  # ellipses first, then the ok trials
    np.testing.assert_allclose(points, np.array([[0.2, 0.1], [-0.4, 0.3]]))
    # The legend's entries are returned for the caller to place off the data.
    assert ax.get_legend() is None
    assert "2 trials used" in [h.get_label() for h in handles]
    assert note == ""  # nothing beyond the frame
    assert png_bytes(fig).startswith(b"\x89PNG")


def test_dominant_inputs_count_ok_trials_per_session() -> None:
    table = dominant_inputs(_trials())
    assert table.to_dict("records") == [
        {"session": "s.mcap", "dominant_input": "pixels", "trials": 1, "median_share": 0.6},
        {"session": "s.mcap", "dominant_input": "x translation", "trials": 1, "median_share": 0.9},
    ]
    assert figure_key("scatter", 3, "/x/method2_ground.mcap") == "scatter_03_method2_ground"


def test_the_report_answers_first_and_keeps_wide_tables_in_their_box(
    tmp_path: Path, point_session: Path
) -> None:
    from analysis.batch.runner import run

    out = tmp_path / "out"
    run([point_session], out, scene=False)
    page = re.sub(r"<script>.*?</script>", "", (out / "report.html").read_text(), flags=re.S)
    answer = page.index("id='answer'")
    assert answer < page.index("id='summary'") < page.index("id='sessions'")
    assert "href='#answer'" in page  # the table of contents
    assert page.count("<div class='scroll'><table") == page.count("<table")  # every table
    assert "e-15" not in page  # floating-point noise reads 0
    assert "e-16" not in page


def _wide_trials(n: int, seed: int = 0) -> pd.DataFrame:
    rng = np.random.default_rng(seed)
    sigma = rng.uniform(0.1, 3.0, (n, 2))
    return pd.DataFrame(
        {
            "session": "s.mcap",
            "trial": np.arange(1, n + 1),
            "units": "in",
            "status": "ok",
            "err_x": rng.normal(0, 1, n),
            "err_y": 0.0,
            "err_z": rng.normal(0, 1, n),
            "err": rng.uniform(0.1, 2, n),
            "sigma_x": sigma[:, 0],
            "sigma_z": sigma[:, 1],
            "cov_xz": 0.5 * sigma[:, 0] * sigma[:, 1],
            "warning": ["plane angle 1.0 deg < 5 deg" if k % 4 == 0 else "" for k in range(n)],
        }
    )


def test_error_scatter_keeps_every_ellipse_inside_the_axes() -> None:
    trials = _wide_trials(12)
    fig = Figure()
    ax = fig.add_subplot()
    handles, _ = plot_error_scatter(ax, trials, "t")
    clean = trials[trials["warning"] == ""]
    half_x = np.sqrt(CHI2_95[2]) * clean["sigma_x"]
    half_z = np.sqrt(CHI2_95[2]) * clean["sigma_z"]
    (x0, x1), (z0, z1) = ax.get_xlim(), ax.get_ylim()
    assert len(clean) == 9
    assert ((clean["err_x"] - half_x) >= x0).all()
    assert ((clean["err_x"] + half_x) <= x1).all()
    assert ((clean["err_z"] - half_z) >= z0).all()
    assert ((clean["err_z"] + half_z) <= z1).all()
    # The warned trials are drawn apart, named, and without ellipses.
    labels = [h.get_label() for h in handles]
    assert "3 warned (left out)" in labels
    assert "9 trials used" in labels
    assert len(np.asarray(ax.collections[0].get_offsets())) == 9  # ellipses: the clean trials only


def _averaging(n_trials: int) -> tuple[pd.DataFrame, pd.DataFrame]:
    frames = np.arange(1, 6)
    averaging = pd.DataFrame(
        {
            "trial": np.repeat(np.arange(1, n_trials + 1), len(frames)),
            "n_frames": np.tile(frames, n_trials),
            "x": 1.0,
            "y": 9.625,
            "z": 10.0,
        }
    )
    trials = _wide_trials(n_trials).assign(gt_x=1.0, gt_y=9.625, gt_z=10.0)
    return averaging, trials


def test_running_average_names_every_series_or_draws_small_multiples() -> None:
    averaging, trials = _averaging(MAX_LEGEND)
    fig = session_figures("s.mcap", trials, averaging, pd.DataFrame())["averaging"]
    axes = [ax for ax in fig.axes if ax.get_visible() and ax.axison]
    assert len(axes) == 2
    # One legend, below the panels (never on the data), naming every trial.
    assert all(ax.get_legend() is None for ax in axes)
    labels = [t.get_text() for t in fig.legends[0].get_texts()]
    named = list("trial " + trials["trial"].astype(str))
    assert labels[:MAX_LEGEND] == named
    assert "warned trial (left out)" in labels  # drawn dashed, and said so
    for ax in axes:
        (lines,) = [c for c in ax.collections if isinstance(c, LineCollection)]
        colours = {tuple(c) for c in np.asarray(lines.get_colors())}
        assert len(colours) == MAX_LEGEND  # no colour repeats
    # The error (not the estimate), with its unit, and the two panels on one y scale.
    assert axes[0].get_ylabel() == "error of the running average (in)"
    assert fig.get_supxlabel() == "number of frames averaged per pose"
    assert "running average, error" in fig.get_suptitle()
    assert axes[0].get_ylim() == axes[1].get_ylim()
    # Beyond MAX_LEGEND: the same two panels, each trial a line coloured by its number,
    # with a colour key; a warned trial dashed.
    averaging, trials = _averaging(40)
    fig = session_figures("s.mcap", trials, averaging, pd.DataFrame())["averaging"]
    panels = fig.axes
    assert [ax.get_title() for ax in panels] == ["x error", "z error"]
    for ax in panels:
        (lines,) = [c for c in ax.collections if isinstance(c, LineCollection)]
        assert len(lines.get_segments()) == 40
        assert len({tuple(c) for c in np.asarray(lines.get_colors())}) > MAX_LEGEND
    (key,) = [
        a
        for a in fig.get_children()
        if isinstance(a, PolyCollection) and a.get_label() == "<colour key>"
    ]
    assert len(key.get_paths()) == 40
    assert "trial number (colour key)" in [t.get_text() for t in fig.texts]
    assert panels[0].get_ylim() == panels[1].get_ylim()
    assert panels[0].get_ylabel() == "error of the running average (in)"
    assert "warned trial (left out)" in [t.get_text() for t in fig.legends[0].get_texts()]


def test_figures_cost_the_same_whatever_the_trial_count() -> None:
    """The artists a session's figures draw do not grow with the trials."""

    def artists(n: int) -> int:
        averaging, trials = _averaging(n)
        views = pd.DataFrame(
            {
                "trial": np.repeat(trials["trial"], 2),
                "t_x": 0.0,
                "t_z": 0.0,
                "ray_x": 0.1,
                "ray_z": 1.0,
            }
        )
        trials = trials.assign(x=1.0, z=10.0)
        figures = session_figures("s.mcap", trials, averaging, views)
        return sum(len(ax.get_children()) for fig in figures.values() for ax in fig.axes)

    assert artists(30) == artists(300)


def test_every_run_figure_has_a_title(tmp_path: Path, point_session: Path) -> None:
    from analysis.batch.runner import run

    result = run([point_session], None, scene=False)
    assert len(make_figures(result)) >= 5
    for name, fig in make_figures(result).items():
        panels = [ax for ax in fig.axes if ax.axison]
        titled = fig.get_suptitle() or all(ax.get_title() for ax in panels)
        assert titled, name
        # Every axis is named, with its unit (a count or a trial number needs none).
        xs = [fig.get_supxlabel(), *(ax.get_xlabel() for ax in panels)]
        ys = [fig.get_supylabel(), *(ax.get_ylabel() for ax in panels)]
        for labels in (xs, ys):
            named = [label for label in labels if label]
            assert named, name
            for label in named:
                assert "(in" in label or label.startswith(("number of", "trial number")), label
        assert "session units" not in str(xs + ys)


def test_thesis_verdict_counts_trials_within_one_inch_in_any_unit() -> None:
    trials = pd.DataFrame(
        {
            "method": ["point", "point", "ground", "ground", "line"],
            "units": ["in", "in", "mm", "mm", "in"],
            "status": "ok",
            "err": [0.5, 0.9, 20.0, 30.0, 0.3],  # 30 mm is 1.18 in
            "err_x": [0.1, 0.1, 1.0, 1.0, 0.1],
            "warning": ["", "", "", "", ""],
        }
    )
    lines = thesis_verdict(trials)
    assert lines[0].startswith("ground (method 2): 1 of 2 trials within 1 in (largest 1.18 in)")
    assert "line: 1 of 1 trials within 1 in" in lines[1]
    assert "did not test" in lines[1]
    # 1 of 2 within: Fisher's test cannot reject 15 of 15, which is no agreement (before:
    # "consistent with the thesis' 15 of 15").
    assert "can't tell it from the thesis' 15 of 15 (Fisher p = 0.12: too few trials" in lines[0]
    assert "consistent" not in " ".join(lines)
    assert lines[2].startswith("point (method 1): 2 of 2 trials within 1 in")
    # All within on fewer trials than the thesis' 15 is no reproduction (a new user's r5
    # F4: "1 of 1 ... reproduced"); 15 of 15 is.
    assert "can't tell: all within, as the thesis reports, but on 2 trials" in lines[2]
    assert "reproduced" not in lines[2].replace("too few to call it reproduced", "")
    errors = np.linspace(0.1, 0.9, 15)
    fifteen = pd.DataFrame({"method": ["point"] * 15, "units": "in", "status": "ok",
                            "err": errors, "err_x": 0.1, "warning": ""})  # fmt: skip
    (line,) = thesis_verdict(fifteen)
    assert line.endswith("; reproduced: the thesis reports all within 1 in.")
    for table, said in ((fifteen, "yes"), (trials, "can't tell")):  # the thesis table's row
        row = _within_row(table, _used(table, include_warned=False), Method.POINT, "method 1",
                          include_warned=False)  # fmt: skip
        assert row["reproduced"] == said, row
    # an ok trial left out for its warning is said beside the count, with its error
    left = trials.assign(warning=["", "", "", "plane angle 4.70 deg < 5", ""])
    lines = thesis_verdict(left)
    assert "1 of 1 trials within 1 in (largest 0.79 in)" in lines[0]
    assert "(1 more ok trial warned, left out: 1.18 in)" in lines[0]
    assert "reproduced:" not in lines[0]


def test_answer_table_pools_per_method_and_units() -> None:
    trials = _wide_trials(8).assign(method="point")
    trials.loc[:3, "units"] = "mm"
    table = answer_table(trials)
    assert list(table.columns) == ANSWER_COLUMNS
    assert sorted(table["units"]) == ["in", "mm"]
    assert table["n_trials"].sum() == 8


def test_rig_before_after_uses_the_trials_the_summary_uses() -> None:
    """A warned trial (the tool doubts it) is left out of the rig's before/after, as of
    the summary, unless include_warned; a failed trial never counts."""
    from analysis.report.writer import rig_before_after

    trials = pd.DataFrame(
        {
            "session": ["s"] * 4,
            "status": ["ok", "ok", "ok", "degenerate"],
            "warning": ["", "", "plane angle 1.0 deg < 5", ""],
            "err": [1.0, 1.0, 10.0, 50.0],
            "err_rig": [0.5, 0.5, 20.0, 40.0],
            "within95": [True, False, True, False],
            "within95_rig": [1.0, 1.0, 0.0, 0.0],
            "dominant_input": ["systematic", "pixels", "systematic", "pixels"],
        }
    )
    table = rig_before_after(trials).set_index("session")
    assert table.loc["s", "trials"] == 2
    assert table.loc["s", "rmse"] == 1.0
    assert table.loc["s", "rmse_rig_loo"] == 0.5
    assert table.loc["s", "coverage95_rig"] == 1.0
    assert table.loc["s", "systematic_dominant"] == 1
    everything = rig_before_after(trials, include_warned=True).set_index("session")
    assert everything.loc["s", "trials"] == 3
    assert everything.loc["s", "rmse_rig_loo"] == np.sqrt((0.25 + 0.25 + 400) / 3)


def test_the_console_answers_per_session_set_and_ends_with_verdicts_and_the_report(
    tmp_path: Path,
) -> None:
    """Sessions of two sets: the thesis' first, each set's rows under its name, then one
    verdict line per set and method, then where report.html is."""
    from analysis.report.terminal import closing_lines, summary_lines
    from analysis.session.metrics import summarize

    trials = pd.concat(
        [
            _wide_trials(6).assign(session=name, method="point", gt_x=0.0, gt_y=0.0, gt_z=0.0)
            for name in ("/s/stress_point.mcap", "/s/thesis_point.mcap")
        ],
        ignore_index=True,
    )
    lines = summary_lines(trials, summarize(trials), width=None)
    thesis = lines.index("thesis_* sessions: the thesis' experiments, errors in inches:")
    stress = lines.index(
        "stress_* sessions: free poses, some near a degenerate geometry, errors in inches:"
    )
    assert thesis < stress
    assert lines[thesis + 2].startswith("point ")  # under the table's header
    per_session = lines[lines.index("per session:") + 1 :]
    assert per_session[0].startswith("  thesis_point.mcap")
    (tmp_path / "report.html").write_text("<html></html>")
    closing = closing_lines(thesis_verdict(trials), tmp_path, width=None)
    assert [line.split(":")[:2] for line in closing[:2]] == [
        ["verdict", " thesis_*"],
        ["verdict", " stress_*"],
    ]
    assert "point (method 1)" in closing[0]
    assert closing[-1] == f"report: {tmp_path / 'report.html'}"
    assert closing_lines(thesis_verdict(trials), tmp_path / "none", width=None)[-1].startswith(
        "verdict:"
    )


def test_a_verdict_says_the_rows_without_an_estimate_it_leaves_out() -> None:
    """A new user's finding: a session of 8 touches, 4 without an estimate, read "4 of 4
    touches within 1 in"."""
    nan = float("nan")
    trials = pd.DataFrame(
        {
            "method": ["point"] * 4, "units": "in",
            "status": ["ok", "ok", "incomplete", "no_detection"],
            "err": [0.5, 0.2, nan, nan], "err_x": [0.1, 0.1, nan, nan], "warning": "",
        }
    )  # fmt: skip
    (line,) = thesis_verdict(trials)
    assert "2 of 2 trials within 1 in (largest 0.50 in) (2 more of its 4 trials without" in line
    (touches,) = thesis_verdict(trials.assign(cameras=2, touch=list("abcd")))
    assert "(2 more of its 4 touches without an estimate)" in touches
    (clean,) = thesis_verdict(trials[trials["status"] == "ok"])
    assert "without an estimate" not in clean
