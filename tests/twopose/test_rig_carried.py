"""The rig's constants' covariance carried into every region (issue 54, item 5): ``J C J^T``
beside the views' own noise, for every method, the correlations included; what the live
result's options and guidance's predictions take too."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest

from tests.twopose.synthetic_trials import GROUND, trials
from twopose.guidance.prediction import regions95
from twopose.methods.specs import Method, spec_of
from twopose.rig.carried import RIG_INPUT, carried_covariance, corrected_inputs
from twopose.rig.constants import SCALARS, RigConstants, RigCovariance
from twopose.solve.estimate import (
    EstimateOptions,
    ViewBatch,
    measure,
    nearest_on_line,
    thesis_estimate,
)
from twopose.solve.session import SessionEstimate, SessionTrials, estimate_session
from twopose.uncertainty.noise import NoiseModel, PlacingSigma
from twopose.uncertainty.session_noise import placing_source
from twopose.values.units import Units

NAMES = ("mount_ry_deg", "offset_x", "offset_z", "focal_scale", "principal_dx_px", "tape_scale")
SIGMA = np.array([0.05, 0.05, 0.08, 0.004, 1.5, 0.002])
#: offset_x and principal_dx_px correlated at -0.9, as a board finds a sideways shift of the
#: camera and of its principal point hard to tell apart (the sign as their effects cancel).
CORR = np.eye(len(NAMES))
CORR[1, 4] = CORR[4, 1] = -0.9
COV = RigCovariance.of(NAMES, CORR * np.outer(SIGMA, SIGMA))
OFF = EstimateOptions(noise=NoiseModel(test_redundancy=False))


def _session(method: str, seed: int = 0) -> SessionTrials:
    views, truth = trials(method, np.random.default_rng(seed), [3.0, 5.0])
    ground = GROUND if spec_of(method).needs_ground else None
    return SessionTrials(method=Method(method), units=Units.IN, trial_ids=(1, 2), views=views,
                         truth=truth, ground=ground)  # fmt: skip


@pytest.mark.parametrize("method", ["point", "line", "ground"])
def test_the_carried_covariance_is_the_scatter_of_estimates_under_drawn_constants(
    method: str,
) -> None:
    session = _session(method)
    measurements, _, _ = measure(session.views, OFF)
    batch = ViewBatch.of(measurements, session.views)
    solved = thesis_estimate(session.method, batch, session.ground, OFF, np.zeros((2, 3)))
    reference = solved(np.concatenate([batch.inputs, batch.intrinsics], axis=-1))
    carried = carried_covariance(session.method, batch, session.ground, OFF, COV, reference)
    # Monte Carlo: constants drawn from the covariance, every view corrected by them.
    rng = np.random.default_rng(7)
    draws = rng.multivariate_normal(np.zeros(len(NAMES)), COV.array(), size=600)
    nominal = RigConstants().vector()
    index = [SCALARS.index(n) for n in NAMES]
    copies = []
    for d in draws:
        v = nominal.copy()
        v[index] += d
        copies.append(corrected_inputs(batch, RigConstants.from_vector(v)))
    estimate = thesis_estimate(session.method, batch, session.ground, OFF, reference)
    points = estimate(np.concatenate(copies)).reshape(len(draws), 2, 3)
    diagonal = RigCovariance.of(NAMES, np.diag(SIGMA**2))
    independent = carried_covariance(
        session.method, batch, session.ground, OFF, diagonal, reference
    )
    for t in range(2):
        scatter = np.cov(points[:, t].T)
        # 600 draws: each direction's variance to about 6% (1 sigma), so the carried
        # covariance whitened by the scatter has its eigenvalues within 0.8-1.25 of 1; the
        # diagonal alone (the correlation dropped) is further off.
        assert 0.8 < _ratios(carried[t], scatter).min() <= _ratios(carried[t], scatter).max() < 1.25
        assert abs(np.log(_ratios(independent[t], scatter))).max() > 0.4


def _ratios(cov: np.ndarray, reference: np.ndarray) -> np.ndarray:
    """The eigenvalues of ``cov`` whitened by ``reference`` (1 where they agree), over the
    directions the reference spans to first order (a ground point has none along the
    ground's normal; a line's point moves along the line only to second order)."""
    w, V = np.linalg.eigh(reference)
    keep = w > 1e-3 * w.max()
    W = V[:, keep] / np.sqrt(w[keep])
    return np.linalg.eigvalsh(W.T @ cov @ W)


@pytest.mark.parametrize("method", ["point", "line", "ground"])
def test_every_region_of_a_session_estimate_carries_it(method: str) -> None:
    session = _session(method, seed=3)
    without = estimate_session(session, OFF)
    with_rig = estimate_session(
        session, dataclasses.replace(OFF, noise=dataclasses.replace(OFF.noise, rig=COV))
    )
    added = with_rig.estimates.cov - without.estimates.cov
    assert (np.linalg.eigvalsh(added)[:, -1] > 0).all()  # wider, never narrower
    np.testing.assert_allclose(with_rig.estimates.point, without.estimates.point)
    # The reported point (a line's nearest its truth) carries it as well: trials.csv's.
    from twopose.methods.truth import reported

    assert (np.trace(reported(with_rig).cov, axis1=1, axis2=2)
            > np.trace(reported(without).cov, axis1=1, axis2=2)).all()  # fmt: skip
    # Guidance's predicted regions (the recorder's live options) are wider with it too.
    before = regions95(session, OFF)
    after = regions95(session, with_rig.options)
    assert (after > before).all(), (before, after)


def test_a_rig_known_worse_than_the_views_dominates_the_region() -> None:
    session = _session("point", seed=5)
    loose = RigCovariance.of(("offset_x",), [[1.0]])  # an inch: it outweighs everything
    est = estimate_session(session, dataclasses.replace(OFF, noise=NoiseModel(rig=loose)))
    assert list(est.estimates.dominant) == [RIG_INPUT, RIG_INPUT]
    assert (est.estimates.dominant_share > 0.5).all()


def test_a_line_reports_the_carried_covariance_across_itself() -> None:
    session = _session("line", seed=2)
    est = estimate_session(session, dataclasses.replace(OFF, noise=NoiseModel(rig=COV)))
    d = est.estimates.direction
    along = np.einsum("ti,tij,tj->t", d, est.estimates.cov, d)
    assert np.allclose(along, 0.0, atol=1e-9 * np.abs(est.estimates.cov).max())
    assert nearest_on_line is not None  # the thesis' line reports its nearest point


@pytest.mark.parametrize("method", ["point", "line", "ground"])
def test_a_boards_sigma_is_an_estimate_even_without_the_sessions_test(method: str) -> None:
    # A board's placing sigma rests on its degrees of freedom: with --no-sigma0 (nothing
    # estimated from the session) its regions still take Fisher's F on them, never the
    # sigma as exact (bench_placing: 91% coverage for points that way); a sigma stated
    # without its 1-sigma is exact (an upper bound is not taken: test_rig_file).
    session = _session(method)
    measured = PlacingSigma(sigma_in=0.1, sigma_sigma_in=0.1 / math.sqrt(2 * 17),
                            measured_by="board.mcap", captures=16)  # fmt: skip
    exact = PlacingSigma(sigma_in=0.1, measured_by="board.mcap", captures=16)

    def estimate(placing: PlacingSigma) -> SessionEstimate:
        return estimate_session(session, EstimateOptions(noise=NoiseModel(
            placing=placing, test_redundancy=False)))  # fmt: skip

    on_17, as_exact = estimate(measured), estimate(exact)
    assert on_17.factor is not None
    assert as_exact.factor is None
    assert on_17.factor.variance_dof == pytest.approx(17)
    assert on_17.factor.placing_variance == 1.0  # the board's sigma itself, only less sure
    wider = (
        np.linalg.eigvalsh(on_17.estimates.cov)[:, -1]
        / np.linalg.eigvalsh(as_exact.estimates.cov)[:, -1]
    )
    assert np.all(wider > 1.01)
    assert np.all(wider < 1.6)
    assert placing_source(EstimateOptions(noise=NoiseModel(placing=measured)), on_17.factor) == (
        "measured by board.mcap (16 captures), times 1 (estimated from board.mcap alone)"
    )
