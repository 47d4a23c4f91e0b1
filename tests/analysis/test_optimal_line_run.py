"""The reprojection-optimal line in `run`: beside the thesis' line in trials.csv
(``x_optimal``..., ``angle_err_optimal_deg``, ``dist_err_optimal``), the thesis' line itself
with two views, and read by ``compare --estimator-b optimal`` for line runs."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from analysis import analyse_session
from analysis.batch.runner import run
from analysis.gate.comparison import compare_runs
from twopose.methods.specs import Method


def test_two_views_report_the_thesis_line(line_session: Path) -> None:
    t = analyse_session(line_session).trials
    ok = t["status"] == "ok"
    assert ok.any()
    for a in "xyz":
        np.testing.assert_allclose(t.loc[ok, f"{a}_optimal"], t.loc[ok, a], atol=1e-6)
    np.testing.assert_allclose(t.loc[ok, "angle_err_optimal_deg"], t.loc[ok, "angle_err_deg"])
    np.testing.assert_allclose(t.loc[ok, "err_optimal"], t.loc[ok, "dist_err_optimal"])


@pytest.mark.slow
def test_three_views_in_the_run_and_in_compare(tmp_path: Path) -> None:
    from recorder.simulate.one_camera import simulate_session

    session = tmp_path / "sessions" / "line3.mcap"
    session.parent.mkdir()
    simulate_session(session, method=Method.LINE, trials=4, frames=3, seed=12, poses=3)
    out = tmp_path / "out"
    result = run([session.parent], out, scene=False)
    t = result.trials
    ok = t["status"] == "ok"
    assert ok.sum() >= 3
    columns = ["x_optimal", "err_optimal", "angle_err_optimal_deg", "dist_err_optimal"]
    assert set(columns) <= set(t.columns)
    assert np.isfinite(t.loc[ok, columns].to_numpy(dtype=float)).all()
    assert (t.loc[ok, "angle_err_optimal_deg"] < 5.0).all()
    # Three views: a line of its own, not the thesis' one.
    assert not np.allclose(t.loc[ok, "x_optimal"], t.loc[ok, "x"], atol=1e-9)
    comparison = compare_runs(out, out, estimator_b="optimal")
    tests = comparison.tests
    assert list(tests["method"]) == ["line"]
    assert int(tests["n_pairs"].iloc[0]) >= 1
