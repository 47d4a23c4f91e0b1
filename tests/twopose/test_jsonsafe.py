"""The one JSON encoder of what the recorder shows live: NaN and infinity become null,
wherever they sit (twopose/values/jsonsafe.py)."""

from __future__ import annotations

import json
import math

import numpy as np

from recorder.live.trial_result import TrialResult
from twopose.methods.specs import Method
from twopose.values import jsonsafe
from twopose.values.units import Units


def strict(text: str) -> object:
    def refuse(name: str) -> None:
        raise AssertionError(f"{name} in JSON")

    return json.loads(text, parse_constant=refuse)


def test_non_finite_values_become_null_anywhere() -> None:
    value = {
        "a": math.nan,
        "b": [1.0, math.inf, (-math.inf, 2)],
        "c": {"d": np.float64("nan"), "e": np.array([1.5, np.nan])},
        "f": np.int64(3),
        "g": np.bool_(True),
        "h": "NaN",
        5: None,
    }
    assert strict(jsonsafe.dumps(value)) == {
        "a": None,
        "b": [1.0, None, [None, 2]],
        "c": {"d": None, "e": [1.5, None]},
        "f": 3,
        "g": True,
        "h": "NaN",
        "5": None,
    }


def test_a_degenerate_trial_result_is_strict_json() -> None:
    """A line with no baseline: NaN point, direction, covariance (issue 21's 500)."""
    nan3 = (math.nan, math.nan, math.nan)
    result = TrialResult(
        trial=1, method=Method.LINE, units=Units.IN, n_views=2, status="degenerate",
        reason="no baseline", point=nan3, direction=nan3, semiaxis95=math.inf, ci95=nan3,
        margins={"parallax_deg": math.nan}, cov=(nan3, nan3, nan3),
    )  # fmt: skip
    data = strict(jsonsafe.dumps(result.to_json()))
    assert isinstance(data, dict)
    assert data["direction"] == [None, None, None]
    assert data["semiaxis95"] is None
    assert data["margins"] == {"parallax_deg": None}
    assert data["cov"] == [[None] * 3] * 3
