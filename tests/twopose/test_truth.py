"""twopose.methods.truth directly: a line's errors against known geometry, the point a line reports
(nearest the true midpoint, or the solved point with no truth), and points compared with
their first true point."""

from __future__ import annotations

import numpy as np

from tests.twopose.synthetic_trials import estimate as _estimate
from tests.twopose.synthetic_trials import trials as _trials
from twopose.methods.truth import line_errors, reported, reported_line_point


def test_line_errors_of_a_known_offset_and_tilt() -> None:
    # The true segment on the x axis from 0 to 4; the estimate passes 0.5 above its midpoint,
    # tilted 30 degrees, and is given the other way round (a line has no arrow).
    point = np.array([[2.0, 0.5, 0.0]])
    direction = -np.array([[np.cos(np.radians(30)), np.sin(np.radians(30)), 0.0]])
    nearest, mid, angle, dist = line_errors(
        point, direction, np.array([[0.0, 0, 0]]), np.array([[4.0, 0, 0]])
    )
    np.testing.assert_allclose(mid, [[2.0, 0, 0]])
    np.testing.assert_allclose(angle, [30.0])
    # The nearest point of the estimate to (2, 0, 0), and its distance.
    np.testing.assert_allclose(dist, [0.5 * np.cos(np.radians(30))])
    np.testing.assert_allclose(np.linalg.norm(nearest - mid, axis=1), dist)
    np.testing.assert_allclose(np.cross(nearest - point, direction), 0.0, atol=1e-12)


def test_a_line_without_truth_reports_its_solved_point() -> None:
    point = np.array([[1.0, 2.0, 3.0], [0.0, 0.0, 5.0]])
    direction = np.array([[1.0, 0, 0], [0, 1.0, 0]])
    truth = np.array([[[0.0, 0, 0], [4.0, 0, 0]], [[np.nan] * 3] * 2])
    out, mid = reported_line_point(point, direction, truth)
    np.testing.assert_allclose(out[0], [2.0, 2.0, 3.0])  # moved along x to the midpoint's
    np.testing.assert_array_equal(out[1], point[1])
    assert np.isnan(mid[1]).all()


def test_a_point_is_compared_with_its_first_true_point() -> None:
    views, truth = _trials("point", np.random.default_rng(13), [1.0, 2.0])
    estimate = _estimate("point", views, truth)
    rep = reported(estimate)
    np.testing.assert_array_equal(rep.point, estimate.estimates.point)
    np.testing.assert_array_equal(rep.reference, truth[:, 0])
    np.testing.assert_allclose(rep.error, rep.point - truth[:, 0])
    np.testing.assert_array_equal(rep.cov, estimate.estimates.cov)
    assert (np.linalg.norm(rep.error, axis=1) < 0.3).all()


def test_a_line_is_reported_at_its_point_nearest_the_true_midpoint() -> None:
    """twopose.methods.truth: the reported point lies on the estimated line, nearest the true
    midpoint, and its covariance is propagated there (not at the solved point): no
    variance along the line, and different from the solved point's where they differ."""
    views, truth = _trials("line", np.random.default_rng(11), [1.0, 2.0, 3.0])
    estimate = _estimate("line", views, truth)
    est, rep = estimate.estimates, reported(estimate)
    mid = truth.mean(axis=1)
    np.testing.assert_allclose(rep.reference, mid)
    np.testing.assert_allclose(rep.error, rep.point - mid)
    # on the line, and the offset to the midpoint is perpendicular to it
    offset = rep.point - est.point
    cross = np.cross(offset, est.direction)
    np.testing.assert_allclose(cross, 0.0, atol=1e-9)
    np.testing.assert_allclose(np.einsum("ti,ti->t", mid - rep.point, est.direction), 0, atol=1e-9)
    along = np.einsum("ti,tij,tj->t", est.direction, rep.cov, est.direction)
    np.testing.assert_allclose(along, 0.0, atol=1e-12)
    moved = np.linalg.norm(offset, axis=1) > 0.5
    assert moved.any()
    assert not np.allclose(rep.cov[moved], est.cov[moved])
    # with no truth, the solved point and its covariance
    none = reported(_estimate("line", views, np.full_like(truth, np.nan)))
    np.testing.assert_array_equal(none.point, est.point)
    np.testing.assert_array_equal(none.cov, est.cov)
    assert np.isnan(none.reference).all()
