"""A pose's frames combined: doubled-angle averages, mean / median / robust, frames not found."""

from __future__ import annotations

import numpy as np
import pytest

from twopose.detect.frames import combine_frames


def test_doubled_angles_average_89_and_minus_89_to_90() -> None:
    m = combine_frames(np.zeros((2, 2)), np.array([89.0, -89.0]), np.array([True, True]))
    assert m.theta_deg == pytest.approx(90.0)
    assert m.theta_std_deg == pytest.approx(np.std([-1.0, 1.0], ddof=1))


def test_mean_median_and_robust() -> None:
    c = np.array([[100.0, 50.0], [100.2, 50.1], [99.8, 49.9], [100.1, 50.0], [130.0, 70.0]])
    th = np.array([10.0, 10.2, 9.8, 10.1, 40.0])
    found = np.ones(5, bool)
    mean = combine_frames(c, th, found, "mean")
    np.testing.assert_allclose(mean.centroid_px, c.mean(axis=0))
    median = combine_frames(c, th, found, "median")
    np.testing.assert_allclose(median.centroid_px, (100.1, 50.0))
    robust = combine_frames(c, th, found, "robust")
    assert robust.rejected == (4,)
    assert robust.n_used == 4
    np.testing.assert_allclose(robust.centroid_px, c[:4].mean(axis=0))
    assert robust.theta_deg == pytest.approx(10.025, abs=0.01)


def test_frames_not_found_are_ignored_and_none_found_is_not_found() -> None:
    c = np.array([[1.0, 2.0], [np.nan, np.nan], [3.0, 4.0]])
    m = combine_frames(c, np.full(3, np.nan), np.array([True, False, True]))
    assert m.found
    assert m.n_used == 2
    assert m.n_frames == 3
    np.testing.assert_allclose(m.centroid_px, (2.0, 3.0))
    assert np.isnan(m.theta_deg)
    none = combine_frames(c, np.full(3, np.nan), np.zeros(3, bool))
    assert not none.found
