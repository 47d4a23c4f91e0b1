"""benchmarks/bench_noise.py's coverage cells (issue 54): several operators a cell, each
operator's multiplier learned from their own sessions alone, and a cell's interval by a
cluster bootstrap over operators and their sessions; a cell whose whole interval lies
outside 93-97% is a miss (exit 1)."""

from __future__ import annotations

import math

import numpy as np
import pandas as pd
import pytest

from tests.helpers import load_benchmark
from twopose.methods.specs import Method
from twopose.uncertainty.noise import VarianceFactor, region_quantile

bench = load_benchmark("bench_noise")


def _cell(per_operator: list[float], sessions: int = 20, trials: int = 2, size: int = 2,
          placing: float = 1.6) -> pd.DataFrame:  # fmt: skip
    """A cell of operators whose trials are inside their regions at the given shares."""
    rows = []
    for j, share in enumerate(per_operator):
        inside = np.arange(sessions * trials) < round(share * sessions * trials)
        np.random.default_rng(j).shuffle(inside)
        rows.append(pd.DataFrame({
            "method": "point", "placing": placing, "size": size, "operator": j,
            "session": j * sessions + np.repeat(np.arange(sessions), trials),
            "within": inside, "alone": inside, "typed": inside, "given": inside,
            "nees": 1.0, "ratio": 1.0, "lam": 1.0, "dof": 40.0,
        }))  # fmt: skip
    return pd.concat(rows, ignore_index=True)


def test_a_cells_interval_carries_the_spread_between_its_operators() -> None:
    # the same 95.0% of 160 trials: all four operators at 95%, or at 85, 100, 100 and 95%
    even, uneven = _cell([0.95] * 4), _cell([0.85, 1.0, 1.0, 0.95])
    assert even["within"].mean() == uneven["within"].mean() == 0.95
    lo_e, hi_e = bench.cluster_interval(even)
    lo_u, hi_u = bench.cluster_interval(uneven)
    assert lo_e < 0.95 < hi_e
    assert lo_u < 0.95 < hi_u
    # trials as if independent: the binomial's +-1.96 sigma is 6.8 points wide
    binomial = 2 * 1.96 * math.sqrt(0.95 * 0.05 / len(even))
    assert hi_u - lo_u > 1.3 * binomial > hi_e - lo_e


def test_a_cell_misses_only_where_its_whole_interval_is_outside_the_band(
    capsys: pytest.CaptureFixture[str],
) -> None:
    cells = pd.concat([
        _cell([0.92] * 4, size=2),  # 92% but the band inside its interval: not a miss
        _cell([0.85] * 4, size=3),  # 85%: its whole interval below 93%
        _cell([0.95] * 4, size=4),
        _cell([1.0] * 4, size=5),  # 100%: above 97%
    ], ignore_index=True)  # fmt: skip
    missed = bench.report_coverage(cells)
    cell_misses = [m for m in missed if "trials a session" in m]
    assert len(cell_misses) == 2
    assert "3 trials a session: regions cover 85.0%" in cell_misses[0]
    assert "5 trials a session: regions cover 100.0%" in cell_misses[1]
    assert "85.0%" in capsys.readouterr().out


def test_each_operators_multiplier_comes_from_their_own_sessions_alone(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    monkeypatch.setattr(bench, "METHODS", (Method.POINT,))
    monkeypatch.setattr(bench, "PLACINGS", (3.0,))
    monkeypatch.setattr(bench, "SIZES", (2,))
    cells = bench.coverage_rows(3, 0, operators=2)
    assert sorted(set(cells["operator"])) == [0, 1]
    s0 = 1000 * 2 + 30
    second = [bench.session(Method.POINT, s0 + 7919 * k, 2, 3.0) for k in range(3, 6)]
    alone = bench.run_pooled(second, "whoever")  # the second operator's sessions only
    got = cells[cells["operator"] == 1].groupby("session")["lam"].first().to_numpy()
    want = [e.factor.placing_variance for e in alone]
    np.testing.assert_allclose(got, want, rtol=1e-12)
    # pooled with the first operator's sessions the multipliers differ
    both = bench.run_pooled(
        [bench.session(Method.POINT, s0 + 7919 * k, 2, 3.0) for k in range(6)], "whoever"
    )
    assert not np.allclose([e.factor.placing_variance for e in both[3:]], want, rtol=1e-3)


@pytest.mark.parametrize(("k", "dof", "share"), [(3, 8.0, 1.0), (2, 20.0, 1.0), (3, 10.0, 0.6)])
def test_a_region_with_an_estimated_multiplier_covers_95_percent(
    k: int, dof: float, share: float
) -> None:
    """The regions carry the multiplier's own uncertainty (issue 54: "always used, with its
    uncertainty"): a k-dimensional error whose placing part (``share`` of its variance at
    the truth) has a multiplier estimated on ``dof`` degrees of freedom falls inside the
    region widened by :meth:`VarianceFactor.widening` 95% of the time; unwidened, less."""
    rng = np.random.default_rng(54)
    n, lam = 40_000, 2.56
    rest, placing = 1.0 - share, share  # the two parts' variances at the true multiplier
    lam_hat = lam * rng.chisquare(dof, n) / dof
    error2 = (rest + placing) * rng.chisquare(k, n)  # squared, in units of its variance
    assumed = rest + placing * lam_hat / lam
    # the placing's share of the region as the estimate says it, as the pipeline reads it
    h = placing * lam_hat / lam / assumed
    widen = np.array([VarianceFactor(sigma0_sq=1.0, dof=0, placing_variance=v,
                                     variance_dof=dof).widening(k, s)
                      for v, s in zip(lam_hat[:4000], h[:4000], strict=True)])  # fmt: skip
    q = region_quantile(k)
    inside = error2[:4000] <= q * assumed[:4000] * widen
    plain = error2 <= q * assumed
    assert abs(inside.mean() - 0.95) < 0.012
    assert plain.mean() < 0.94 if share == 1.0 else plain.mean() < 0.945


def _clean(per_operator: list[float], trials: int = 40, size: int = 3) -> pd.DataFrame:
    """A blunder table's clean trials, each operator's regions over their blunder-absent
    ones at one ratio (an operator's trials share its multiplier), a little spread."""
    rows = []
    for j, ratio in enumerate(per_operator):
        spread = np.random.default_rng(j).normal(0.0, 0.002, trials)
        rows.append(pd.DataFrame({
            "method": "line", "size": size, "poses": 3, "operator": j, "blunder": False,
            "flagged": False, "truth": False, "named": 0, "right": False, "within": True,
            "ratio": ratio + spread, "absent": ratio + spread, "seen": False,
        }))  # fmt: skip
    return pd.concat(rows, ignore_index=True)


def test_a_blunders_cost_to_clean_regions_is_judged_over_operators() -> None:
    """The clean trials' regions against the blunder-absent session's: the median's interval
    resamples operators (the trials of one move together with its multiplier), so one
    operator's draw cannot pass or fail a method alone; a widening every operator shows
    (1.05) is a miss, one whose interval reaches below 1.02 is not."""
    spread = _clean([0.97, 1.01, 1.03, 1.07])
    low, high = bench.median_interval(spread, "absent")
    assert low < 1.0 < 1.05 < high  # the operators' spread, not the trials'
    blundered = _clean([1.0]).assign(blunder=True, flagged=True).head(10)
    for table, widened in ((spread, False), (_clean([1.05, 1.06, 1.05, 1.06]), True)):
        missed = bench.report_blunders(pd.concat([table, blundered], ignore_index=True))
        assert any("widened" in m for m in missed) is widened, missed
