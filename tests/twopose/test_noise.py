"""twopose.noise's quantiles (scipy.special's functions, not scipy.stats' objects, so that
a re-run imports no scipy.stats) are the distributions' own, and the lower-tail words'
shortcut (sigma0 >= 1 is never in the lower tail) agrees with the quantile."""

from __future__ import annotations

import pytest
from hypothesis import given
from hypothesis import strategies as st
from scipy import stats

from twopose.noise import FACTOR_TEST_LEVEL, chi2_quantile, f_quantile, noise_words

levels = st.floats(0.01, 0.99)
dofs = st.integers(1, 400)


@given(levels, dofs)
def test_the_chi_square_quantile_is_scipy_stats(level: float, dof: int) -> None:
    assert chi2_quantile(level, dof) == pytest.approx(stats.chi2.ppf(level, dof), rel=1e-9)


@given(levels, dofs, dofs)
def test_fishers_quantile_is_scipy_stats(level: float, num: int, den: int) -> None:
    expected = stats.f.ppf(level, num, den)
    assert f_quantile(level, num, den) == pytest.approx(expected, rel=1e-8)


@given(st.floats(0.05, 3.0), dofs)
def test_the_lower_tail_words_follow_the_quantile(sigma0: float, dof: int) -> None:
    """ "scatter less than the noise model says" exactly when dof sigma0^2 is in the
    chi-square's lower 5% tail, the shortcut for sigma0 >= 1 included."""
    below = dof * sigma0**2 < stats.chi2.ppf(FACTOR_TEST_LEVEL, dof)
    words = noise_words(sigma0, dof, region_widening=1.0)
    assert ("scatter less than the noise model says" in words) == below
    assert not (below and sigma0 >= 1.0)
