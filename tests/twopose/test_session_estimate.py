"""twopose.solve.session directly: seeded synthetic truth projected into typed poses,
through estimate_session() for every method; degenerate trials flagged, not solved; the
estimate never reads the truth (twopose.methods.truth compares with it: test_truth.py)."""

from __future__ import annotations

import numpy as np
import pytest

from tests.twopose.synthetic_trials import FRAMES, H
from tests.twopose.synthetic_trials import estimate as _estimate
from tests.twopose.synthetic_trials import trials as _trials
from twopose.methods.specs import spec_of
from twopose.solve.session import running_estimates


@pytest.mark.parametrize("method", ["point", "line", "ground"])
def test_every_method_recovers_seeded_truth(method: str) -> None:
    rng = np.random.default_rng(7)
    views, truth = _trials(method, rng, [1.0, 1.5, 2.0, 3.0])
    estimate = _estimate(method, views, truth)
    assert estimate.complete.all()
    assert estimate.detected.all()
    est = estimate.estimates
    assert list(est.status) == ["ok"] * 4, list(est.reason)
    if method == "line":  # the line through both true points, its direction along them
        d_true = (truth[:, 0] - truth[:, 1]) / np.linalg.norm(truth[:, 0] - truth[:, 1], axis=1)[
            :, None
        ]
        cos = np.abs(np.einsum("ti,ti->t", est.direction, d_true))
        assert (cos > np.cos(np.radians(3))).all(), cos
        assert set(est.margins) == set(spec_of("line").margins)
    else:
        err = np.linalg.norm(est.point - truth[:, 0], axis=1)
        assert (err < 0.3).all(), err  # inches, from 0.3 px frame noise
        if method == "ground":
            np.testing.assert_allclose(est.point[:, 1], H)  # on the ground plane
    # Every estimate carries a finite, symmetric covariance.
    assert np.isfinite(est.cov).all()
    np.testing.assert_allclose(est.cov, np.swapaxes(est.cov, 1, 2), atol=1e-12)


@pytest.mark.parametrize("method", ["point", "line", "ground"])
def test_a_trial_without_baseline_is_flagged_not_solved(method: str) -> None:
    rng = np.random.default_rng(8)
    views, truth = _trials(method, rng, [2.0, 0.0])  # the second trial: one camera centre
    est = _estimate(method, views, truth).estimates
    assert est.status[0] == "ok"
    assert est.status[1] == "degenerate"
    assert "no baseline" in str(est.reason[1])


def test_a_trial_with_one_pose_is_incomplete() -> None:
    rng = np.random.default_rng(9)
    views, truth = _trials("point", rng, [2.0, 2.0])
    views[1] = views[1][:1]
    estimate = _estimate("point", views, truth)
    assert list(estimate.complete) == [True, False]
    assert estimate.measurements[1] == []
    est = estimate.estimates
    assert est.status[0] == "ok"
    assert est.status[1] == "incomplete"
    assert not np.isfinite(est.point[1]).any()


@pytest.mark.parametrize("method", ["point", "line", "ground"])
def test_the_estimate_does_not_read_the_truth(method: str) -> None:
    """The same trials with their truth, with none, and with another: every estimate,
    covariance and warning the same (what is compared with the truth is twopose.methods.truth's)."""
    views, truth = _trials(method, np.random.default_rng(10), [1.0, 2.0, 3.0])
    runs = [_estimate(method, views, t) for t in (truth, np.full_like(truth, np.nan), truth + 5)]
    first = runs[0].estimates
    assert (first.status == "ok").all()
    for other in runs[1:]:
        est = other.estimates
        for name in ("point", "direction", "optimal", "weighted_line", "optimal_line", "cov"):
            np.testing.assert_array_equal(getattr(est, name), getattr(first, name))
        assert list(est.dominant) == list(first.dominant)
        assert other.warnings == runs[0].warnings


def test_running_estimates_use_the_first_frames_of_each_pose() -> None:
    views, truth = _trials("point", np.random.default_rng(12), [1.5, 2.5])
    estimate = _estimate("point", views, truth)
    keys, solved = running_estimates(estimate)
    assert keys == [(i, n) for i in range(2) for n in range(1, FRAMES + 1)]
    assert solved is not None
    # with every frame, the running estimate is the session's estimate
    last = [k for k, (_, n) in enumerate(keys) if n == FRAMES]
    np.testing.assert_allclose(solved.point[last], estimate.estimates.point)
