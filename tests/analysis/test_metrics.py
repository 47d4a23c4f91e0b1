"""metrics: errors against truth and the per-session summary, on hand-made tables."""

from __future__ import annotations

import numpy as np
import pandas as pd
import pytest

from analysis.session.metrics import summarize
from analysis.tables.columns import SUMMARY_COLUMNS
from twopose.methods.truth import line_errors
from twopose.uncertainty.propagate import uncertainty_columns


def test_line_errors_of_a_shifted_tilted_line() -> None:
    # True line: the x axis. Estimate: through (0, 1, 0), tilted 30 deg in the x-y plane.
    gt_a, gt_b = np.array([[-2.0, 0.0, 0.0]]), np.array([[2.0, 0.0, 0.0]])
    t = np.radians(30.0)
    direction = np.array([[np.cos(t), np.sin(t), 0.0]])
    nearest, mid, angle, dist = line_errors(np.array([[0.0, 1.0, 0.0]]), direction, gt_a, gt_b)
    np.testing.assert_allclose(mid, [[0.0, 0.0, 0.0]])
    np.testing.assert_allclose(angle, [30.0])
    # The point of the estimated line nearest the origin, and its distance.
    np.testing.assert_allclose(dist, [np.cos(t)], atol=1e-12)
    np.testing.assert_allclose(np.linalg.norm(nearest), dist)


def test_line_angle_ignores_the_arrow() -> None:
    gt_a, gt_b = np.array([[0.0, 0.0, 0.0]]), np.array([[0.0, 0.0, 5.0]])
    _, _, angle, _ = line_errors(np.zeros((1, 3)), np.array([[0.0, 0.0, -1.0]]), gt_a, gt_b)
    np.testing.assert_allclose(angle, [0.0], atol=1e-6)


def _trials(errors: list[tuple[float, float, float]], status: list[str]) -> pd.DataFrame:
    e = np.array(errors)
    return pd.DataFrame(
        {
            "session": "s.mcap",
            "method": "point",
            "units": "in",
            "trial": range(1, len(e) + 1),
            "status": status,
            "err_x": e[:, 0],
            "err_y": e[:, 1],
            "err_z": e[:, 2],
            "err": np.linalg.norm(e, axis=1),
        }
    )


def test_summary_uses_ok_trials_only() -> None:
    trials = _trials(
        [(0.3, 0.0, 0.4), (-0.1, 0.0, 0.0), (9.0, 9.0, 9.0)], ["ok", "ok", "degenerate"]
    )
    (row,) = summarize(trials).to_dict("records")
    assert list(summarize(trials).columns) == SUMMARY_COLUMNS
    assert (row["n_trials"], row["n_ok"]) == (3, 2)
    assert row["bias_x"] == pytest.approx(0.1)
    assert row["std_x"] == pytest.approx(np.std([0.3, -0.1], ddof=1))
    assert row["rmse"] == pytest.approx(np.sqrt((0.5**2 + 0.1**2) / 2))
    assert row["max_err"] == pytest.approx(0.5)
    assert row["within_1"] == 1.0


def test_summary_of_a_session_with_no_ok_trial_is_nan_not_an_error() -> None:
    (row,) = summarize(_trials([(1.0, 0.0, 0.0)], ["no_detection"])).to_dict("records")
    assert row["n_ok"] == 0
    assert np.isnan([row["bias_x"], row["rmse"], row["median_err"]]).all()


def test_uncertainty_columns_of_a_known_covariance() -> None:
    cov = np.diag([4.0, 1.0, 0.25])[None]
    cols = uncertainty_columns(np.array([[2.0, 0.0, 0.0]]), cov)
    np.testing.assert_allclose(
        np.array([cols["sigma_x"], cols["sigma_y"], cols["sigma_z"]]), [[2.0], [1.0], [0.5]]
    )
    np.testing.assert_allclose(cols["nees"], [1.0])  # (2 / 2)^2
    assert cols["nees_dof"][0] == 3
    assert cols["within95"][0] == 1.0
    np.testing.assert_allclose(cols["ci95_x"], [1.959964 * 2], rtol=1e-6)
    far = uncertainty_columns(np.array([[20.0, 0.0, 0.0]]), cov)
    assert far["within95"][0] == 0.0


def test_warned_trials_are_counted_and_left_out_unless_asked() -> None:
    """The headline is over the trials the tool does not doubt; the all-ok figures beside."""
    trials = _trials([(0.1, 0.0, 0.0), (0.3, 0.0, 0.0), (10.0, 0.0, 0.0)], ["ok"] * 3)
    trials["warning"] = ["", "", "plane angle 0.12 deg < 5"]
    trials["within95"] = [True, False, False]
    (row,) = summarize(trials).to_dict("records")
    assert (row["n_ok"], row["n_warned"], row["n_used"]) == (3, 1, 2)
    assert row["rmse"] == pytest.approx(np.sqrt((0.1**2 + 0.3**2) / 2))
    assert row["max_err"] == pytest.approx(0.3)
    assert row["max_err_all_ok"] == pytest.approx(10.0)
    assert row["rmse_all_ok"] > 5
    assert row["coverage95"] == 0.5
    # No interval over 2 trials (issue 56: the bootstrap's was their smaller and larger error).
    for column in ("bias_x_ci95", "rmse_ci95_low", "rmse_ci95_high"):
        assert np.isnan(row[column]), column
    (everything,) = summarize(trials, include_warned=True).to_dict("records")
    assert everything["n_used"] == 3
    assert everything["max_err"] == pytest.approx(10.0)


def test_intervals_start_at_five_trials() -> None:
    """From :data:`MIN_INTERVAL_TRIALS` trials on, the 95% t-interval of each bias and the
    RMSE's bootstrap interval; from one fewer, none."""
    from analysis.session.metrics import MIN_INTERVAL_TRIALS

    errors = [0.1, 0.3, 0.2, 0.6, 0.4]
    assert len(errors) == MIN_INTERVAL_TRIALS
    (row,) = summarize(_trials([(e, 0.0, 0.0) for e in errors], ["ok"] * 5)).to_dict("records")
    assert row["bias_x_ci95"] == pytest.approx(2.776 * np.std(errors, ddof=1) / np.sqrt(5))
    assert row["rmse_ci95_low"] < row["rmse"] < row["rmse_ci95_high"]
    (fewer,) = summarize(_trials([(e, 0.0, 0.0) for e in errors[:4]], ["ok"] * 4)).to_dict(
        "records"
    )
    assert np.isnan(fewer["bias_x_ci95"])
    assert np.isnan(fewer["rmse_ci95_low"])


@pytest.mark.filterwarnings("error")
def test_a_warning_column_read_back_empty_warns_of_nothing() -> None:
    """trials.csv read back with no warning at all has a float NaN column: no trial is
    warned, and pandas is not asked to fill floats with text (a warning, an error in 4)."""
    from analysis.session.metrics import warned

    assert not warned(pd.DataFrame({"warning": [np.nan, np.nan]})).any()
    assert warned(pd.DataFrame({"warning": ["", "near-degenerate", None]})).tolist() == [
        False,
        True,
        False,
    ]
