"""Second-order propagation (issue 54): every region also carries the estimate's curvature.

The divided differences' second-order term (:func:`twopose.uncertainty.propagate.propagate`
with ``second_order``): exact where the estimate is quadratic in each input, first order
in the small-noise limit and where the estimate is linear (the thesis' estimates in the
typed translations), never narrower, and closer to the real solver's scatter where a
typed rotation's error bends it.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Callable

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

import twopose.solve.session as session_module
from tests.twopose.synthetic_trials import GROUND, estimate, project, trials, view
from twopose.methods.specs import Method, spec_of
from twopose.solve.estimate import EstimateOptions, PoseView, thesis_estimate
from twopose.solve.session import SessionEstimate, SessionTrials, estimate_session
from twopose.uncertainty.noise import NoiseModel, PlacingPrior
from twopose.uncertainty.placing_variance import posterior, trial_information, trial_loglik
from twopose.uncertainty.propagate import PLACING, propagate
from twopose.uncertainty.session_noise import placing_parts
from twopose.values.units import Units

F64 = NDArray[np.float64]
#: Three poses whose rays and planes meet well (the planes at 10-20 degrees).
POSES = (np.zeros(3), np.array([1.5, 0.0, 0.0]), np.array([3.0, 0.5, -1.0]))


def _separable(a: F64, b: F64) -> Callable[[F64], F64]:
    """f(x) = sum_k a_k x_k + b_k x_k^2 per output (T rows of (N, 9) inputs, 3 outputs)."""
    T = a.shape[0]

    def f(x: F64) -> F64:
        reps = x.shape[0] // T
        A, B = np.tile(a, (reps, 1, 1, 1)), np.tile(b, (reps, 1, 1, 1))
        return np.asarray(np.einsum("tinj,tnj->ti", A, x) + np.einsum("tinj,tnj->ti", B, x**2))

    return f


@settings(max_examples=25, deadline=None)
@given(st.integers(0, 2**32 - 1), st.floats(0.01, 3.0))
def test_second_order_is_the_exact_covariance_of_a_function_quadratic_in_each_input(
    seed: int, scale: float
) -> None:
    """Var(a x + b x^2) = (a + 2 b x0)^2 s^2 + 2 b^2 s^4 for a normal x: the term is exact."""
    rng = np.random.default_rng(seed)
    T, N = 3, 2
    a, b = rng.normal(size=(T, 3, N, 9)), rng.normal(size=(T, 3, N, 9))
    sigma = scale * rng.uniform(0.1, 1.0, size=(T, N, 9))
    sigma[..., 2] = 0.0  # an exact input (a dot's angle) adds nothing
    C = np.einsum("tnj,jk->tnjk", sigma**2, np.eye(9))
    x0 = rng.normal(size=(T, N, 9))
    f = _separable(a, b)
    slope = a + 2 * b * x0[:, None]  # (T, 3, N, 9)
    first = np.einsum("tinj,tnj,tknj->tik", slope, sigma**2, slope)
    second = 2 * np.einsum("tinj,tnj,tknj->tik", b, sigma**4, b)
    out = propagate(f, x0, C, second_order=True)
    np.testing.assert_allclose(out.cov_grid, first + second, rtol=1e-6, atol=1e-9)
    plain = propagate(f, x0, C)
    np.testing.assert_allclose(plain.cov_grid, first, rtol=1e-6, atol=1e-9)
    assert out.curvature is not None
    assert plain.curvature is None


@settings(max_examples=12, deadline=None)
@given(
    st.sampled_from(["point", "line", "ground"]),
    st.integers(0, 2**32 - 1),
    st.floats(1e-4, 1e-2),
)
def test_second_order_is_first_order_in_the_small_noise_limit(
    method: str, seed: int, shrink: float
) -> None:
    """Every input's sigma times ``shrink``: the second-order term vanishes as its square."""
    views, truth = trials(method, np.random.default_rng(seed), [1.0, 2.0])
    est = estimate(method, views, truth)
    p = est._propagation
    assert p is not None
    f = _thesis(method, est)

    def term(C: F64) -> tuple[F64, F64]:
        first = propagate(f, p.batch.inputs, C).cov_grid
        second = propagate(f, p.batch.inputs, C, second_order=True).cov_grid
        return second - first, np.trace(first, axis1=1, axis2=2)

    full, size = term(p.cov_in)
    small, small_size = term(p.cov_in * shrink**2)
    assert np.all(np.linalg.eigvalsh(full) >= -1e-9 * size[:, None])  # never narrower
    # the term goes as sigma^4 (first order as sigma^2): relatively, shrink^2 of the full one
    norm = np.linalg.norm(small, axis=(1, 2)) / small_size
    assert np.all(norm <= 1.5 * shrink**2 * np.linalg.norm(full, axis=(1, 2)) / size + 1e-9)


def _thesis(method: str, est: SessionEstimate) -> Callable[[F64], F64]:
    """The session's thesis estimate as a function of its solved rows' inputs."""
    p = est._propagation
    assert p is not None
    ground = GROUND if spec_of(method).needs_ground else None
    return thesis_estimate(Method(method), p.batch, ground, est.options, p.solved.point)


@pytest.mark.parametrize("method", ["point", "line", "ground"])
def test_the_thesis_estimates_are_linear_in_the_typed_translations(method: str) -> None:
    """No curvature in a pose's translation: first order is exact for the placing error.

    Each view's ray (a point) or plane (a line, the finger) keeps its direction when the
    camera moves; the estimate is the rays' or planes' meeting, linear in where they pass.
    So a placing sigma however large (3x the typed) needs no second order, and the
    placing's second-order part of a region is nil (:func:`placing_parts`).
    """
    views, truth = trials(method, np.random.default_rng(7), [1.0, 1.5, 2.5])
    wide = [[dataclasses.replace(v, t_sigma=0.3) for v in row] for row in views]
    est = estimate(method, wide, truth)
    p = est._propagation
    assert p is not None
    out = propagate(_thesis(method, est), p.batch.inputs, p.cov_in, second_order=True)
    first, second = placing_parts(out, p.cov_in)
    assert np.all(np.abs(second) <= 1e-9 * np.trace(first, axis1=1, axis2=2)[:, None, None])
    assert out.curvature is not None
    c = np.abs(out.curvature[..., PLACING]).max()
    assert c <= 1e-9 * math.sqrt(np.trace(first, axis1=1, axis2=2).max())


def _turned(views: list[PoseView], r_sigma_deg: float) -> list[PoseView]:
    """The views typed with a rotation resolution ``r_sigma_deg`` and exact frames."""
    return [
        dataclasses.replace(v, r_sigma_deg=r_sigma_deg, t_sigma=0.01,
                            centroids=np.repeat(v.centroids.mean(axis=0)[None], len(v.found), 0))
        for v in views
    ]  # fmt: skip


def test_a_region_where_the_rotation_bends_the_estimate_follows_the_solvers_scatter(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    """A point seen from two poses 1.2 in apart, each typed to 1.5 degrees.

    The real solver's scatter, by Monte Carlo over the typed rotations and translations
    (and the detector's floor), is measurably wider than first order's region; the
    session's region (second order) comes closer to it and not beyond it, within the
    draws' standard error. Fails with first-order regions.
    """
    rng = np.random.default_rng(54)
    views, truth = trials("point", rng, [1.2])
    row = _turned(views[0], 1.5)
    options = EstimateOptions(noise=NoiseModel(test_redundancy=False))
    one = SessionTrials(method=Method.POINT, units=Units.IN, trial_ids=(1,), views=[row],
                        truth=truth)  # fmt: skip
    region = np.trace(estimate_session(one, options).estimates.cov[0])
    monkeypatch.setattr(session_module, "SECOND_ORDER", False)
    linear = np.trace(estimate_session(one, options).estimates.cov[0])
    draws = 3000
    floor = 0.05  # the dot's detector floor, px (the region's pixel part)
    copies = [
        [dataclasses.replace(
            v, t_grid=v.t_grid + 0.01 * rng.standard_normal(3),
            r_deg=v.r_deg + 1.5 * rng.standard_normal(3),
            centroids=v.centroids + floor * rng.standard_normal(2))
         for v in row]
        for _ in range(draws)
    ]  # fmt: skip
    many = SessionTrials(method=Method.POINT, units=Units.IN, trial_ids=tuple(range(draws)),
                         views=copies, truth=np.repeat(truth, draws, axis=0))  # fmt: skip
    points = estimate_session(many, options, line_fits=False).estimates.point
    points = points[np.isfinite(points).all(axis=1)]
    scatter = np.trace(np.cov(points.T))
    se = math.sqrt(2.0 / len(points))  # a variance's relative standard error, at most
    assert linear < scatter * (1 - 3 * se)  # first order is optimistic here
    assert region > linear * (1 + 3 * se)  # second order widens it measurably
    assert region < scatter * (1 + 3 * se)  # and not beyond the solver's scatter


def _placed_views(
    method: str, rng: np.random.Generator, trials_n: int, placing: float
) -> tuple[list[list[PoseView]], F64]:
    """Trials of three poses, typed to 1/16 in and placed ``placing`` times worse.

    Exact frames (the pixels err by the detector's floor alone, the same in every frame),
    rotations exact: what the misclosure tests is the placing error.
    """
    spec = spec_of(method)
    floor_px, floor_deg = spec.detector_floor
    views, truth = [], []
    for _ in range(trials_n):
        g = np.array([1.9, GROUND[1], 8.4]) + rng.uniform(-0.5, 0.5, 3) * [1, 0, 1]
        top = g + np.array([0.3, -6.0, 1.5])
        p = np.array([0.5, 1.5, 11.0]) + rng.uniform(-0.5, 0.5, 3)
        row = []
        for k, t_true in enumerate(POSES):
            if spec.uses_image_lines:
                a, b = project(top, t_true), project(g, t_true)
                px = (a + b) / 2
                theta = math.degrees(math.atan2(b[1] - a[1], b[0] - a[0]))
                theta += floor_deg * rng.standard_normal()
            else:
                px, theta = project(p, t_true), math.nan
            px = px + floor_px * rng.standard_normal(2)
            base = view(k + 1, t_true + placing * 0.0625 * rng.standard_normal(3), px, 0.0, rng)
            row.append(dataclasses.replace(
                base, r_sigma_deg=1e-9, centroids=np.repeat(px[None], len(base.found), 0),
                thetas=np.full(len(base.found), theta)))  # fmt: skip
        views.append(row)
        truth.append([top, g] if spec.uses_image_lines else [p, p])
    return views, np.array(truth)


@pytest.mark.parametrize("method", ["point", "ground"])
def test_the_multiplier_from_the_solvers_own_misclosures_is_unbiased_at_3x(method: str) -> None:
    """The misclosure is the iterated adjustment's, the distance to the views' agreement:
    the placing multiplier it gives at 3x the typed is the truth's (9) within its standard
    error (5-8% here; a few percent, as bench_noise's pooled table shows for a point at 3x,
    is below what this test resolves: it guards against a misclosure, or a likelihood of
    the multiplier, that does not follow the placing error)."""
    views, truth = _placed_views(method, np.random.default_rng(3), 500, 3.0)
    trials_ = SessionTrials(method=Method(method), units=Units.IN,
                            trial_ids=tuple(range(len(views))), views=views, truth=truth,
                            ground=GROUND if spec_of(method).needs_ground else None)  # fmt: skip
    m = estimate_session(trials_, EstimateOptions(), line_fits=False).misclosure
    assert m is not None
    good = m.dof > 0
    assert good.mean() > 0.95
    weak = PlacingPrior(scale=1.0, dof=1e-9, source="none")
    post = posterior(trial_loglik(m.placing_share[good], m.z2[good]).sum(axis=0), weak, None,
                     trial_information(m.placing_share[good]).sum(axis=0))  # fmt: skip
    se = math.sqrt(2.0 / post.information)
    assert abs(post.scale / 9.0 - 1.0) < 3 * se
