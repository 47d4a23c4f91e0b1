"""The figures tell the answer's story: the trials the statistics use (warned ones left
out of the run's figures, drawn apart in a session's), the sessions' units on every axis,
one bin width, legends off the data, the top view drawn as the solver solved."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.figure import Figure
from matplotlib.patches import Rectangle

from analysis.report.answer import answer_table
from analysis.report.captions import largest_errors, run_captions
from analysis.report.figures.draw import (
    plot_error_by_trial,
    plot_error_histogram,
    plot_error_vs_baseline,
)
from analysis.report.figures.topview import top_views
from analysis.session.metrics import by_session_set, session_set, used_trials, warned
from analysis.session.pipeline import analyse_session


def _run_trials() -> pd.DataFrame:
    """Two sets, two methods; one warned trial far off (44.4 in), one failed trial."""
    rows = []
    for session, method, errors in (
        ("thesis_point.mcap", "point", [0.3, 0.7, 0.5]),
        ("thesis_ground.mcap", "ground", [0.2, 1.06, 44.4]),
        ("stress_line.mcap", "line", [0.9, 1.39, 10.2]),
    ):
        for k, err in enumerate(errors, start=1):
            warned = err > 10
            rows.append(
                {
                    "session": session,
                    "trial": k,
                    "method": method,
                    "units": "in",
                    "status": "ok",
                    "err": err,
                    "err_x": err / 2,
                    "err_y": 0.0,
                    "err_z": err / 2,
                    "baseline": 1.0 + k,
                    "semiaxis95": 2 * err,
                    "warning": "plane angle 1.0 deg < 5 deg" if warned else "",
                }
            )
    rows.append(rows[0] | {"trial": 9, "status": "degenerate", "err": np.nan})
    return pd.DataFrame(rows)


def test_the_histogram_draws_the_answers_trials_with_one_bin_width() -> None:
    trials = _run_trials()
    answer = answer_table(trials)
    fig = Figure()
    plot_error_histogram(fig, trials)
    panels = [ax for ax in fig.axes if ax.axison]
    assert [ax.get_title() for ax in panels] == [
        "Error per trial: thesis_* sessions",
        "Error per trial: stress_* sessions",
    ]
    bars = [
        p for ax in panels for p in ax.patches if isinstance(p, Rectangle) and p.get_height() > 0
    ]
    widths = {round(p.get_width() * len(answer["method"].unique()), 9) for p in bars}
    assert len(widths) == 1  # one bin width (three methods' bars share each bin)
    # The last bin ends at the answer's largest error (1.39, not the warned 44.4): the
    # highest bar is in it (each bin holds a bar per method, side by side).
    top, bin_width = answer["max_err"].max(), answer["max_err"].max() / 20
    assert max(p.get_x() + p.get_width() for p in bars) <= top + 1e-9
    assert max(p.get_x() for p in bars) >= top - bin_width
    assert panels[0].get_ylim() == panels[1].get_ylim()
    assert panels[-1].get_xlabel().startswith("error (in); bins 0.0695 in wide")
    # Legends below the panels, never on them.
    assert all(ax.get_legend() is None for ax in panels)
    assert len(fig.legends) == 1
    # With --include-warned, the warned trials are drawn, as the answer then counts them.
    fig = Figure()
    plot_error_histogram(fig, trials, include_warned=True)
    bars = [
        p for ax in fig.axes for p in ax.patches if isinstance(p, Rectangle) and p.get_height() > 0
    ]
    assert 44.4 - 44.4 / 20 <= max(p.get_x() for p in bars) < 44.4


def test_error_by_trial_and_baseline_draw_no_warned_trial() -> None:
    trials = _run_trials()
    largest = answer_table(trials)["max_err"].max()
    fig = Figure()
    plot_error_by_trial(fig, trials)
    (ax,) = fig.axes
    drawn = [line.get_ydata() for line in ax.get_lines() if line.get_linestyle() == "-"]
    assert max(np.nanmax(y) for y in drawn) == pytest.approx(largest)
    # a left-out trial breaks its session's line (a gap), never joins its neighbours
    gaps = sum(int(np.isnan(np.asarray(y, dtype=float)).sum()) for y in drawn)
    assert gaps == int(warned(used_trials(trials, include_warned=True, measured=True)).sum())
    assert ax.get_ylabel() == "error (in, log scale)"
    assert ax.get_legend() is None
    fig = Figure()
    plot_error_vs_baseline(fig, trials)
    points = np.concatenate([c.get_offsets() for ax in fig.axes for c in ax.collections])
    assert points[:, 1].max() == pytest.approx(largest)
    assert fig.axes[-1].get_xlabel() == "baseline (in)"


def test_mixed_units_are_drawn_in_inches_and_the_captions_agree() -> None:
    trials = _run_trials()
    mm = trials["method"] == "point"
    trials.loc[mm, "units"] = "mm"
    trials.loc[mm, ["err", "err_x", "err_z", "baseline", "semiaxis95"]] *= 25.4
    fig = Figure()
    plot_error_histogram(fig, trials)
    assert "(in)" in fig.axes[-1].get_xlabel()
    captions = run_captions(trials, include_warned=False)
    assert "sessions in other units converted" in captions["error_histogram"]
    assert "1 warned trial(s) left out" not in captions["error_histogram"]
    assert "2 warned trial(s) left out, as there" in captions["error_histogram"]
    largest = {(s, m): v for s, m, v in largest_errors(trials, include_warned=False)}
    assert largest[("thesis", "point")] == pytest.approx(0.7)
    assert largest[("thesis", "ground")] == pytest.approx(1.06)


def test_session_sets_come_from_the_file_names() -> None:
    assert session_set("/x/sessions/thesis_method1_point.mcap") == "thesis"
    assert session_set("C:\\runs\\stress_line.mcap") == "stress"
    assert session_set("my_session.mcap") == ""
    assert session_set("thesis.mcap") == ""
    trials = _run_trials()
    assert [name for name, _ in by_session_set(trials)] == ["thesis", "stress"]
    one = trials[trials["session"].str.startswith("thesis")]
    assert [name for name, _ in by_session_set(one)] == [""]  # one group: no sets told
    assert used_trials(trials)["err"].max() == pytest.approx(1.39)


@pytest.mark.parametrize("method", ["point", "ground", "line"])
def test_the_top_view_meets_at_the_estimate(
    method: str, point_session: Path, ground_session: Path, line_session: Path
) -> None:
    """Method 1: the rays pass by the estimate; method 2: the plane traces cross at it
    (the ground point, not the finger); a line: the line drawn passes through it."""
    session = {"point": point_session, "ground": ground_session, "line": line_session}[method]
    r = analyse_session(session)
    drawn = top_views(r.trials, r.views)
    assert drawn
    for d in drawn:
        estimate = np.array(d.view.estimate)
        kinds = {kind for kind, _, _ in d.view.segments}
        assert kinds == {"point": {"ray"}, "ground": {"trace"}, "line": {"estimated_line"}}[method]
        for _, start, end in d.view.segments:
            a, b = np.array(start), np.array(end)
            along = (b - a) / np.linalg.norm(b - a)
            off = estimate - a
            distance = abs(off[0] * along[1] - off[1] * along[0])
            tolerance = 0.2 if method == "point" else 1e-6  # rays of noisy dots nearly meet
            assert distance < tolerance, (method, d.view.trial, distance)
