"""recorder.live.trial_result directly: the live result is the analysis' estimate and error for each
trial, its one-line text says why when there is none, and its JSON has no NaN."""

from __future__ import annotations

import json

import numpy as np
import pytest

from recorder.live.trial_result import trial_results
from tests.twopose.synthetic_trials import estimate as _estimate
from tests.twopose.synthetic_trials import trials as _trials
from twopose.methods.specs import Method
from twopose.methods.truth import line_errors, reported
from twopose.solve.session import SessionTrials
from twopose.values.jsonsafe import dumps
from twopose.values.units import Units


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
    said = "no estimate: the poses' geometry is degenerate"
    assert results[2].text() == f"trial 3 (2 views): {said}: {results[2].reason}"
    assert ": degenerate:" not in results[2].text()  # the code word, never shown
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
        units=Units.CM,
        trial_ids=(7,),
        views=[views[0][:1]],
        truth=truth,
    )
    (result,) = trial_results(trials)
    assert result.status == "incomplete"
    assert result.text().startswith("trial 7 (1 views): no estimate yet: fewer than two usable")
    for code in ("incomplete", "no_detection"):
        assert code not in result.text()


def test_a_line_says_its_angle_and_distance_errors_with_their_regions() -> None:
    """A line is judged by both: its angle error as trials.csv's angle_err_deg, and its
    distance error, each with a 95% region (the direction's propagated half-angle)."""
    views, truth = _trials("line", np.random.default_rng(24), [1.0, 2.0])
    estimate = _estimate("line", views, truth)
    est = estimate.estimates
    _, _, angle, _ = line_errors(est.point, est.direction, truth[:, 0], truth[:, 1])
    for i, r in enumerate(trial_results(estimate.trials)):
        assert r.angle_err_deg == pytest.approx(angle[i])  # trials.csv's angle_err_deg
        assert 0 < r.angle95_deg < 90
        text = r.text()
        assert f"angle error {r.angle_err_deg:.1f} deg" in text
        assert f"distance error {r.error:.3f} in (95% within {r.semiaxis95:.3f} in)" in text
        assert f"95% within {r.angle95_deg:.1f} deg" in text


def test_the_angle_region_covers_the_true_direction() -> None:
    """The direction's 95% half-angle holds the true line's angle in about 95% of
    seeded trials (pixel noise only, as propagated)."""
    inside = total = 0
    for seed in range(12):
        views, truth = _trials("line", np.random.default_rng(100 + seed), [1.0, 1.5, 2.0] * 4)
        for r in trial_results(_estimate("line", views, truth).trials):
            if r.status == "ok" and np.isfinite(r.angle95_deg):
                total += 1
                inside += r.angle_err_deg <= r.angle95_deg
    assert total >= 100
    assert 0.85 <= inside / total <= 1.0, (inside, total)


def test_an_error_beyond_its_region_is_warned_in_words() -> None:
    """A line whose typed truth is 35 degrees off: the result says the error is beyond its
    95% region (the page colours it as a warning), never only a distance that looks fine."""
    views, truth = _trials("line", np.random.default_rng(25), [2.0])
    tilted = truth.copy()
    tilted[:, 1] = tilted[:, 0] + (truth[:, 1] - truth[:, 0]) @ np.array(
        [[1.0, 0.0, 0.0], [0.0, 0.82, 0.57], [0.0, -0.57, 0.82]]
    )
    (good,) = trial_results(_estimate("line", views, truth).trials)
    (bad,) = trial_results(_estimate("line", views, tilted).trials)
    assert not good.outside95
    assert bad.outside95
    assert bad.angle_err_deg > 20
    assert "beyond its 95% region" in bad.text()
    assert json.loads(dumps(bad.to_json()))["outside95"] is True
