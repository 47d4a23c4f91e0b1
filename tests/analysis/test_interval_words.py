"""Why no interval is shown, in the rows' own words (a new user's finding: a two-camera
session's answer said "none (4 trials: an interval needs 5)" of its four touches)."""

from __future__ import annotations

import pandas as pd

from analysis.gate.comparison import describe_test
from analysis.report.answer import readable


def _summary(cameras: int, n_used: int) -> pd.DataFrame:
    return pd.DataFrame([{
        "method": "point", "units": "in", "cameras": cameras, "n_used": n_used, "rmse": 0.1,
        "rmse_ci95_low": float("nan"), "rmse_ci95_high": float("nan"), "median_err": 0.1,
        "max_err": 0.2, "within_1": 1.0, "bias_x": 0.01, "bias_x_ci95": float("nan"),
        "bias_z": 0.02, "bias_z_ci95": float("nan"), "n_trials": n_used, "n_ok": n_used,
        "n_warned": 0, "coverage95": 1.0,
    }])  # fmt: skip


def test_too_few_touches_are_said_as_touches_and_trials_as_trials() -> None:
    touches = readable(_summary(2, 4)).iloc[0]
    trials = readable(_summary(1, 1)).iloc[0]
    said = [v for v in touches.to_numpy() if isinstance(v, str) and "interval needs" in v]
    assert said == ["none (4 touches: an interval needs 5)"]
    assert "none (1 trial: an interval needs 5)" in trials.to_numpy().tolist()
    row = pd.Series({"n_pairs": 4, "method": "point", "cameras": 2, "ci95_low": float("nan"),
                     "ci95_high": float("nan"), "mean_diff": 0.01, "units": "in",
                     "p_value": 0.5, "n_b_better": 2, "n_a_better": 2})  # fmt: skip
    assert "(no interval: 4 touches: an interval needs 5)" in describe_test(row)


def test_a_two_camera_sessions_line_says_no_typed_placing() -> None:
    """Its touches have no typed pose: "placing sigma - in typed; sigma0 not tested" was
    said of them (a new user's finding); a one-camera row still says its noise model."""
    from analysis.report.answer import noise_phrases

    row = {"units": "in", "placing_sigma": float("nan"), "placing_source": "",
           "sigma0": float("nan"), "sigma0_dof": 0}  # fmt: skip
    assert noise_phrases(pd.Series({**row, "cameras": 2})) == []
    assert "sigma0 not tested" in " ".join(noise_phrases(pd.Series({**row, "cameras": 1})))
