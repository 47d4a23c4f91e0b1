"""The report reads at a glance (issue 34): the axes framed by the trials the statistics
use (a left-out trial drawn at the edge, listed with its value, never setting the scale),
one colour per trial in every figure of a session, the truth drawn on top, integer ticks
for counts, units named where known, human labels and the answer's rounding in every
table; and a re-run reuses the figures nothing changed."""

from __future__ import annotations

import dataclasses
import shutil
from pathlib import Path

import numpy as np
import pandas as pd
import pytest
from matplotlib.collections import LineCollection, PathCollection
from matplotlib.colors import to_rgba
from matplotlib.figure import Figure
from matplotlib.ticker import MaxNLocator

from analysis.batch.cache import SessionCache
from analysis.batch.runner import run
from analysis.report.figures.cache import FigureCache, FigureJob
from analysis.report.figures.draw import plot_error_histogram, session_figures
from analysis.results import AnalysisOptions
from analysis.session.metrics import used_trials, warned
from analysis.session.pipeline import analyse_session
from analysis.tables.columns import TRIAL_TABLE_COLUMNS
from twopose.values.units import Units

SESSIONS = Path(__file__).resolve().parents[2] / "sessions"


@pytest.fixture(scope="module")
def stress_ground() -> FigureJob:
    return FigureJob.of(analyse_session(SESSIONS / "stress_method2_ground.mcap"))


@pytest.fixture(scope="module")
def averaged() -> FigureJob:
    return FigureJob.of(analyse_session(SESSIONS / "thesis_averaging_ground.mcap"))


def _figures(job: FigureJob) -> dict[str, Figure]:
    return session_figures(job.session, job.trials, job.averaging, job.views, units=job.units)


def _rgba(colour: object) -> tuple[float, ...]:
    return tuple(round(v, 6) for v in to_rgba(colour))  # type: ignore[arg-type]


def test_one_colour_per_trial_in_every_figure_of_a_session(averaged: FigureJob) -> None:
    figures = _figures(averaged)
    assert set(figures) == {"scatter", "topview", "averaging"}
    trials = used_trials(averaged.trials, include_warned=True).sort_values("trial")
    # scatter: the trials' points (the second collection, after the ellipses), in order
    (scatter,) = figures["scatter"].axes
    points = next(c for c in scatter.collections if isinstance(c, PathCollection))
    by_scatter = [_rgba(c) for c in points.get_facecolor()]
    # running averages: one line per trial, in trial order
    panel = figures["averaging"].axes[0]
    (lines,) = [c for c in panel.collections if isinstance(c, LineCollection)]
    by_average = [_rgba(c) for c in lines.get_colors()]
    # top view: the estimates (marker x), one per trial in the order drawn
    top = figures["topview"].axes[0]
    estimates = [c for c in top.collections if isinstance(c, PathCollection)][1]
    by_top = [_rgba(c) for c in estimates.get_facecolor()]
    assert len(set(by_scatter)) == len(trials) == 3
    assert by_scatter == by_average == by_top  # trial 2 is one colour everywhere


def test_the_truth_is_drawn_over_the_rays(averaged: FigureJob) -> None:
    top = _figures(averaged)["topview"].axes[0]
    rays = max(c.get_zorder() for c in top.collections if isinstance(c, LineCollection))
    truth = [c for c in top.collections if isinstance(c, PathCollection)][-2:]
    assert all(c.get_zorder() > rays for c in truth)
    truths = used_trials(averaged.trials, include_warned=True)[["gt_x", "gt_z"]].to_numpy()
    np.testing.assert_allclose(np.asarray(truth[0].get_offsets()), truths)


def test_left_out_trials_never_set_the_scale_and_are_drawn_at_the_edge(
    stress_ground: FigureJob,
) -> None:
    ok = used_trials(stress_ground.trials, include_warned=True, measured=True)
    doubted = warned(ok)
    used, left_out = ok[~doubted], ok[doubted]
    far = left_out[left_out["err_z"].abs() > 10]
    assert len(far) >= 2  # the stress session's warned trials lie tens of inches away
    figures = _figures(stress_ground)
    (ax,) = figures["scatter"].axes
    (z0, z1) = ax.get_ylim()
    assert z1 < far["err_z"].abs().min()  # the far trials did not stretch the frame
    assert z1 - z0 < 20  # the used trials (and their ellipses) fill it
    assert used["err_z"].between(z0, z1).all()
    # each far trial: an arrowhead at the edge, and its trial and value under the legend
    note = " ".join(t.get_text() for t in figures["scatter"].texts).replace("\n", " ")
    assert note.startswith("\u25b2 beyond the frame, drawn at its edge:")
    for _, row in far.iterrows():
        assert f"trial {row['trial']} ({row['err_x']:+.3g}, {row['err_z']:+.3g} in)" in note
    arrows = [c for c in ax.collections if isinstance(c, PathCollection) and c.get_zorder() == 8]
    edge = np.concatenate([np.asarray(c.get_offsets()) for c in arrows])
    assert len(edge) == len(far)
    assert (edge[:, 1] <= z1).all()
    # the top view too: framed by the used trials, the far estimates at its edge
    top = figures["topview"].axes[0]
    assert top.get_ylim()[1] < 20
    assert "beyond the frame" in " ".join(t.get_text() for t in figures["topview"].texts)
    # --include-warned: the warned trials are used, so they set the frame
    job = dataclasses.replace(stress_ground, include_warned=True)
    wide = session_figures(
        job.session, job.trials, job.averaging, job.views, include_warned=True, units=Units.IN
    )
    (ax,) = wide["scatter"].axes
    assert ax.get_ylim()[1] > far["err_z"].max()


def test_counts_have_integer_ticks_and_an_empty_session_names_its_units() -> None:
    trials = pd.DataFrame(
        {
            "session": "s.mcap",
            "trial": [1, 2, 3],
            "method": "point",
            "units": "cm",
            "status": "ok",
            "err": [0.1, 0.2, 0.25],
            "warning": "",
        }
    )
    fig = Figure()
    plot_error_histogram(fig, trials)
    locator = fig.axes[0].yaxis.get_major_locator()
    assert isinstance(locator, MaxNLocator)
    ticks = locator.tick_values(0, 1.8)
    assert np.allclose(ticks, np.round(ticks))  # never 0.25 of a trial
    empty = pd.DataFrame(columns=TRIAL_TABLE_COLUMNS)  # an empty session's trials
    figures = session_figures("e.mcap", empty, pd.DataFrame(), pd.DataFrame(), units=Units.MM)
    (ax,) = figures["scatter"].axes
    assert ax.get_xlabel() == "x error (mm)"
    assert "session units" not in ax.get_ylabel()
    assert ax.get_ylim()[1] - ax.get_ylim()[0] > 1  # not +-8e-11


def test_the_report_tables_read_in_words_with_the_answers_rounding(bundled_run: Path) -> None:
    page = (bundled_run / "report.html").read_text()
    for raw in ("<th>err_x</th>", "<th>semiaxis95</th>", "<th>gt_x</th>", ">format_version<"):
        assert raw not in page
    for shown in ("error x (in)", "95% region, largest semi-axis (in)", "truth x (in)"):
        assert shown in page
    assert "session format version" in page
    assert "RMS error, point (method 1) (in)" in page  # the sensitivity table
    trials = pd.read_csv(bundled_run / "trials.csv")
    first = trials.iloc[0]
    assert f">{first['err']:.2f}<" in page


@pytest.mark.slow  # four runs into one folder (~18 s): make test-all and CI run it
def test_a_rerun_reuses_the_figures_nothing_changed(
    tmp_path: Path, point_session: Path, line_session: Path, ground_session: Path
) -> None:
    """Four runs into one folder (two-trial simulated sessions: with two 15-trial samples
    this took ~18 s)."""
    sessions = tmp_path / "sessions"
    sessions.mkdir()
    for session in (point_session, line_session):
        shutil.copy(session, sessions / session.name)
    out = tmp_path / "out"
    figures = AnalysisOptions(figures=("png",))  # drawn only when asked
    first = run([sessions], out, scene=False, options=figures)
    assert first.figures_reused == 0
    drawn = {p.name: p.read_bytes() for p in out.glob("*_0?_*.png")}
    assert len(drawn) == 6
    again = run([sessions], out, scene=False, options=figures)
    assert again.figures_reused == 2
    assert {p.name: p.read_bytes() for p in out.glob("*_0?_*.png")} == drawn
    # another rule for warned trials: other figures, drawn anew
    assert run([sessions], out, scene=False, options=_warned_in()).figures_reused == 0
    # one session more: the others' figures are reused (by content, not by position)
    shutil.copy(ground_session, sessions / "another.mcap")
    assert run([sessions], out, scene=False, options=_warned_in()).figures_reused == 2
    # a figure replaced since by another PNG (another session's) is drawn again (issue 56:
    # outputs are checked by their bytes' digest, as the run that wrote them recorded it)
    job = FigureJob.of(analyse_session(sessions / "line.mcap"), include_warned=True)
    written = SessionCache.of(out, _warned_in()).written_digests()
    assert FigureCache.of(out, written=written).reuse(job) is not None
    line, point = (next(out.glob(f"scatter_*_{name}.png")) for name in ("line", "point"))
    line.write_bytes(point.read_bytes())
    assert FigureCache.of(out, written=written).reuse(job) is None
    # a figure file that is not a PNG any more is drawn again, not copied
    (next(out.glob("scatter_*_line.png"))).write_bytes(b"not a png")
    cache = FigureCache.of(out)
    assert cache.reuse(job) is None


def _warned_in() -> AnalysisOptions:
    return AnalysisOptions(include_warned=True, figures=("png",))
