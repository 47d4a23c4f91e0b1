"""analysis.report.figures.topview directly: the report's top view is the core's geometry rebuilt
from trials.csv and views.csv, so the rays of method 1 and the ground traces of method 2
pass through the estimate the table reports; warned trials are marked; one artist per kind."""

from __future__ import annotations

from pathlib import Path

import matplotlib

matplotlib.use("Agg")

import numpy as np
import pandas as pd
import pytest
from matplotlib.collections import PolyCollection
from matplotlib.figure import Figure

from analysis.report.figures.topview import plot_top_view, top_views
from analysis.session.metrics import used_trials, warned


def _tables(run: Path, name: str) -> tuple[pd.DataFrame, pd.DataFrame]:
    trials = pd.read_csv(run / "trials.csv")
    views = pd.read_csv(run / "views.csv")
    pick = trials["session"].str.contains(name)
    session = trials.loc[pick, "session"].iloc[0]
    return trials[pick], views[views["session"] == session]


def _off_segment(p: tuple[float, float], a: tuple[float, float], b: tuple[float, float]) -> float:
    d, e = np.subtract(b, a), np.subtract(p, a)
    return float(abs(d[0] * e[1] - d[1] * e[0]) / np.linalg.norm(d))


# Two planes and the ground meet in one point: the traces pass through it exactly; two noisy
# rays are skew, and the estimate is their closest approach's midpoint: they pass close by.
@pytest.mark.parametrize(
    ("name", "kind", "within"),
    [("thesis_method1_point", "ray", 0.01), ("thesis_method2_ground", "trace", 1e-6)],
)
def test_what_each_view_measured_meets_at_the_reported_estimate(
    bundled_run: Path, name: str, kind: str, within: float
) -> None:
    trials, views = _tables(bundled_run, name)
    drawn = top_views(trials, views)
    ok = used_trials(trials, include_warned=True)
    assert [d.view.trial for d in drawn] == ok["trial"].tolist()
    assert [d.warned for d in drawn] == warned(ok).tolist()
    for d, (_, row) in zip(drawn, ok.iterrows(), strict=True):
        estimate = d.view.estimate
        assert estimate is not None
        assert estimate == pytest.approx((row["x"], row["z"]))
        assert d.truth == pytest.approx((row["gt_x"], row["gt_z"]))
        segments = [s for s in d.view.segments if s[0] == kind]
        assert len(segments) == 2  # one per view
        for _, a, b in segments:
            assert _off_segment(estimate, a, b) < within


def test_without_the_view_geometry_nothing_is_drawn(bundled_run: Path) -> None:
    trials, views = _tables(bundled_run, "thesis_method1_point")
    assert top_views(trials, views.drop(columns=["fx"])) == []
    assert top_views(trials, views.iloc[:0]) == []


def test_the_figure_has_one_artist_per_kind_and_a_colour_key(bundled_run: Path) -> None:
    trials, views = _tables(bundled_run, "thesis_method2_ground")
    fig = Figure(figsize=(6.4, 4.8))
    plot_top_view(fig, trials, views, "thesis_method2_ground")
    (ax,) = fig.axes  # the key is drawn on the figure, not as another axes
    (key,) = [
        a
        for a in fig.get_children()
        if isinstance(a, PolyCollection) and a.get_label() == "<colour key>"
    ]
    assert len(key.get_paths()) == trials["trial"].nunique()  # a swatch per trial
    assert "trial number (colour key)" in [t.get_text() for t in fig.texts]
    assert len(ax.collections) <= 6  # collections, not an artist per trial
    assert "(in)" in ax.get_xlabel()
    assert fig.legends  # below the axes, not on the data
