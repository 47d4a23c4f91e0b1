"""twopose.trial_result directly: the live result is the analysis' estimate and error for each
trial, its one-line text says why when there is none, and its JSON has no NaN."""

from __future__ import annotations

import json

import numpy as np
import pytest

from tests.twopose.synthetic_trials import estimate as _estimate
from tests.twopose.synthetic_trials import trials as _trials
from twopose.jsonsafe import dumps
from twopose.methods import Method
from twopose.session_estimate import SessionTrials
from twopose.trial_result import trial_results
from twopose.truth import reported


@pytest.mark.parametrize("method", ["point", "line", "ground"])
def test_each_result_is_the_analysis_estimate_and_error(method: str) -> None:
    views, truth = _trials(method, np.random.default_rng(21), [1.0, 2.0, 0.0])
    estimate = _estimate(method, views, truth)
    rep = reported(estimate)
    results = trial_results(estimate.trials)
    assert [r.trial for r in results] == [1, 2, 3]
    assert [r.status for r in results] == ["ok", "ok", "degenerate"]
    for i, r in enumerate(results[:2]):
        np.testing.assert_allclose(r.point, rep.point[i])
        assert r.error == pytest.approx(float(np.linalg.norm(rep.error[i])))
        assert r.semiaxis95 > 0
        assert (r.direction is not None) == (method == "line")
        assert f"trial {r.trial} (2 views): x " in r.text()
        assert f"error {r.error:.3f} in" in r.text()
    assert results[2].text() == f"trial 3 (2 views): degenerate: {results[2].reason}"
    assert "no baseline" in results[2].reason


def test_the_json_carries_the_text_and_writes_nan_as_null() -> None:
    views, truth = _trials("point", np.random.default_rng(22), [2.0])
    trials = _estimate("point", views, np.full_like(truth, np.nan)).trials
    (result,) = trial_results(trials)
    assert np.isnan(result.error)  # no truth
    assert "error" not in result.text()
    payload = json.loads(dumps(result.to_json()))
    assert payload["error"] is None
    assert payload["error_xyz"] == [None, None, None]
    assert payload["text"] == result.text()
    assert len(payload["cov"]) == 3


def test_an_incomplete_trial_says_so() -> None:
    views, truth = _trials("point", np.random.default_rng(23), [2.0])
    trials = SessionTrials(
        method=Method.POINT,
        units="cm",
        trial_ids=(7,),
        views=[views[0][:1]],
        truth=truth,
    )
    (result,) = trial_results(trials)
    assert result.status == "incomplete"
    assert result.text().startswith("trial 7 (1 views): incomplete: ")
