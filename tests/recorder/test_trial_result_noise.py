"""The live result says the noise model's test (issue 46): a session placed worse than typed
has its regions widened, said in the operator's words, and guidance takes the session's
factor instead of estimating one from its predicted views."""

from __future__ import annotations

import math

from recorder.live.result import guidance_options
from recorder.live.trial_result import trial_results
from tests.helpers import load_benchmark
from twopose.methods.specs import Method
from twopose.solve.estimate import EstimateOptions
from twopose.uncertainty.noise import NoiseModel, VarianceFactor

bench = load_benchmark("bench_sigma0")


def test_a_widened_region_is_said_in_the_live_result() -> None:
    results = trial_results(bench.session(Method.POINT, 3, 2.5 * bench.TYPED_IN, 15))
    ok = [r for r in results if r.status == "ok" and not r.flagged]
    assert ok
    for r in ok:
        assert r.widened > 1.5
        assert "regions' largest semi-axis x" in r.text()
        # sigma0's own test rejects the typed model: said so, with its p-value
        assert "the data contradict the noise model" in r.text()
        assert "(p < 0.001)" in r.text()
        # 2.5 x the typed placing simulated: the session's redundancy estimates it
        assert "placing sigma taken 2." in r.text()
        said = r.to_json()
        assert said["widened"] == r.widened
        assert said["sigma0_dof"] == r.factor.dof > 0  # type: ignore[union-attr]
    fixed = guidance_options(EstimateOptions(), results)
    assert fixed.noise.factor is ok[0].factor  # the session's, applied as is


def test_an_agreeing_session_says_only_what_changed_and_guidance_gets_its_factor() -> None:
    results = trial_results(bench.session(Method.POINT, 1, bench.TYPED_IN, 15))
    ok = [r for r in results if r.status == "ok"]
    assert all(r.widened < 1.1 for r in ok)  # the multiplier's F quantile, ~60 dof
    assert all("largest semi-axis" not in r.text() for r in ok)  # said when a tenth wider
    assert "the data agree with the noise model" in ok[0].noise
    # before any trial: an untested factor, so predicted views never estimate one
    before = guidance_options(EstimateOptions(), [])
    assert before.noise.factor is not None
    assert not before.noise.factor.tested
    given = VarianceFactor(sigma0_sq=2.0, dof=20)
    kept = EstimateOptions(noise=NoiseModel(factor=given))
    assert guidance_options(kept, results) is kept
    two_poses = trial_results(bench.session(Method.LINE, 4, 0.1, 3, poses=(2, 2)))
    assert math.isnan(float(str(two_poses[0].to_json()["sigma0"])))  # untested
