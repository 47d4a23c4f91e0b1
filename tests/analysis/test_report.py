"""report: plots that take an Axes, the console summary cells, the dominant-input counts."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
from matplotlib.figure import Figure

from analysis.report import (
    dominant_inputs,
    error_ellipses,
    figure_key,
    plot_error_scatter,
    png_bytes,
)
from twopose.uncertainty import CHI2_95


def _trials() -> pd.DataFrame:
    return pd.DataFrame(
        {
            "session": "s.mcap",
            "trial": [1, 2, 3],
            "units": "in",
            "status": ["ok", "ok", "degenerate"],
            "err_x": [0.2, -0.4, 5.0],
            "err_z": [0.1, 0.3, 5.0],
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
    np.testing.assert_allclose(ellipses._widths * 2, [2 * k * 0.5, 2 * k * 1.0])
    np.testing.assert_allclose(ellipses._heights * 2, [2 * k * 0.25, 2 * k * 0.5])
    np.testing.assert_allclose(ellipses.get_offsets(), ok[["err_x", "err_z"]].to_numpy())


def test_error_scatter_draws_ok_trials_on_a_given_axes() -> None:
    fig = Figure()
    ax = fig.add_subplot()
    plot_error_scatter(ax, _trials(), "the title")
    assert ax.get_title() == "the title"
    points = ax.collections[1].get_offsets()  # ellipses first, then the ok trials
    np.testing.assert_allclose(points, [[0.2, 0.1], [-0.4, 0.3]])
    assert "2 ok trials" in [t.get_text() for t in ax.get_legend().get_texts()]
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
    from analysis.batch import run

    out = tmp_path / "out"
    run([point_session], out, scene=False)
    page = (out / "report.html").read_text()
    answer = page.index("id='answer'")
    assert answer < page.index("id='summary'") < page.index("id='sessions'")
    assert "href='#answer'" in page  # the table of contents
    assert page.count("<div class='scroll'><table") == page.count("<table")  # every table
    assert "e-15" not in page  # floating-point noise reads 0
    assert "e-16" not in page
