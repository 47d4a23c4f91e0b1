"""First-order uncertainty: propagation, scatter, NEES, and calibration against Monte Carlo."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st
from numpy.typing import NDArray

from twopose.camera.model import rotation_from_angles_deg
from twopose.methods.specs import Method, spec_of
from twopose.solve.nview import (
    image_lines,
    projection_matrices,
    triangulate_ground,
    triangulate_points,
)
from twopose.uncertainty.propagate import (
    CHI2_95,
    INPUT_GROUPS,
    dominant_input,
    enough_frames,
    frame_scatter,
    measurement_covariance,
    nees,
    pooled_scatter,
    propagate,
    region_dof,
    semiaxis95,
    uncertainty_columns,
)
from twopose.values.units import Units

F64 = NDArray[np.float64]
FOCAL = np.array([525.0, 525.0, 320.0, 240.0])


@settings(max_examples=30, deadline=None)
@given(st.integers(0, 2**32 - 1))
def test_propagation_of_a_linear_map_is_exact(seed: int) -> None:
    rng = np.random.default_rng(seed)
    T, N = 4, 3
    A = rng.normal(size=(T, 3, N, 9))
    b = rng.normal(size=(T, 3))
    L = rng.normal(size=(T, N, 9, 9))
    C = L @ np.swapaxes(L, -1, -2) + 1e-3 * np.eye(9)
    x0 = rng.normal(size=(T, N, 9))

    def f(x: F64) -> F64:
        reps = x.shape[0] // T  # propagate stacks perturbed copies of the T rows
        return np.asarray(np.einsum("tinj,tnj->ti", np.tile(A, (reps, 1, 1, 1)), x)) + np.tile(
            b, (reps, 1)
        )

    out = propagate(f, x0, C)
    expected = np.einsum("tinj,tnjk,tlnk->til", A, C, A)
    np.testing.assert_allclose(out.cov_grid, expected, rtol=1e-6, atol=1e-9)
    # The per-group variances split the trace when the groups are uncorrelated.
    block = np.zeros((9, 9), dtype=bool)
    for lo, hi in ((0, 3), (3, 4), (4, 5), (5, 6), (6, 9)):
        block[lo:hi, lo:hi] = True
    out_d = propagate(f, x0, np.where(block, C, 0.0))
    np.testing.assert_allclose(
        out_d.variance_by_group.sum(axis=(1, 2)),
        np.trace(out_d.cov_grid, axis1=1, axis2=2),
        rtol=1e-6,
    )


def test_inputs_with_zero_variance_are_not_perturbed() -> None:
    calls: list[F64] = []

    def f(x: F64) -> F64:
        calls.append(x)
        return x[:, 0, :3].copy()

    C = np.zeros((2, 1, 9, 9))
    C[:, 0, 1, 1] = 4.0
    out = propagate(f, np.zeros((2, 1, 9)), C)
    # One call: the +step and -step copies of the one uncertain input, for both rows.
    assert [c.shape for c in calls] == [(4, 1, 9)]
    np.testing.assert_allclose(out.cov_grid[:, 1, 1], 4.0)
    assert out.cov_grid[:, 0, 0].tolist() == [0.0, 0.0]


def test_frame_scatter_takes_orientation_deviations_across_the_wrap() -> None:
    c = np.array([[10.0, 20.0], [10.2, 20.0], [9.8, 20.0]])
    th = np.array([89.9, -89.9, 90.0])  # one line direction, written three ways
    S, dof = frame_scatter(c, th, np.ones(3, dtype=bool))
    assert dof == 2
    assert S[2, 2] < 0.02  # (0.1 deg)^2 scale, not (90 deg)^2
    np.testing.assert_allclose(S[0, 0], np.var(c[:, 0], ddof=1))
    S_dot, _ = frame_scatter(c, np.full(3, np.nan), np.ones(3, dtype=bool))
    assert S_dot[2].tolist() == [0.0, 0.0, 0.0]
    S_one, dof_one = frame_scatter(c, th, np.array([True, False, False]))
    assert dof_one == 0
    assert not S_one.any()


def test_measurement_covariance_shrinks_toward_the_pooled_scatter() -> None:
    own = np.diag([4.0, 4.0, 0.0])
    pooled = pooled_scatter([(np.diag([1.0, 1.0, 0.0]), 40), (own, 0)])
    np.testing.assert_allclose(pooled, np.diag([1.0, 1.0, 0.0]))
    few = measurement_covariance(own, 4, pooled, n_used=5)
    np.testing.assert_allclose(few[0, 0], (4 * 1.0 + 4 * 4.0) / 8 / 5)
    single = measurement_covariance(np.zeros((3, 3)), 0, pooled, n_used=1)
    np.testing.assert_allclose(single[0, 0], 1.0)  # one frame: the session's scatter
    median = measurement_covariance(own, 4, pooled, n_used=5, median=True)
    np.testing.assert_allclose(median[:2, :2], few[:2, :2] * np.pi / 2)


@pytest.mark.parametrize("method", ["point", "line", "ground"])
def test_the_detectors_floor_stays_however_many_frames_are_averaged(method: str) -> None:
    """The registry's floor is added after the frames' average: many frames of a perfectly
    still target leave exactly the floor (a pose's variance never reaches zero)."""
    floor = spec_of(method).detector_floor
    assert floor[0] > 0
    assert (floor[1] > 0) == spec_of(method).uses_image_lines
    zero = np.zeros((3, 3))
    many = measurement_covariance(zero, 99, zero, n_used=100, floor=floor)
    np.testing.assert_allclose(np.diag(many), [floor[0] ** 2, floor[0] ** 2, floor[1] ** 2])
    noisy = np.diag([1.0, 1.0, 0.5])
    few = measurement_covariance(noisy, 4, noisy, n_used=5, floor=floor)
    np.testing.assert_allclose(np.diag(few), np.diag(noisy) / 5 + np.diag(many))


def test_a_trial_of_still_frames_and_exact_poses_keeps_the_detectors_floor() -> None:
    """Through the whole estimation: frames that never move and poses typed exactly still
    leave the region the detector's floor gives (not a zero region that nothing covers)."""
    from twopose.methods.truth import reported
    from twopose.solve.estimate import EstimateOptions, PoseView
    from twopose.solve.session import SessionTrials, estimate_session

    K = np.array([525.0, 525.0, 320.0, 240.0])
    point = np.array([0.5, 2.0, 11.0])
    views = []
    for pose, x in enumerate((0.0, 2.0), start=1):
        (P,) = projection_matrices(K[None], np.eye(3)[None], np.array([[x, 0.0, 0.0]]))
        h = P @ np.append(point, 1.0)
        view = PoseView(
            pose=pose, intrinsics=K, width_height=(640, 480), t_grid=np.array([x, 0, 0.0]),
            r_deg=np.zeros(3), t_sigma=1e-9, r_sigma_deg=0.0,
            centroids=np.tile(h[:2] / h[2], (5, 1)), thetas=np.full(5, np.nan),
            found=np.ones(5, dtype=bool), camera_id="cam0",
        )  # fmt: skip
        views.append(view)
    trials = SessionTrials(
        method=Method.POINT,
        units=Units.IN,
        trial_ids=(1,),
        views=[views],
        truth=np.array([[point, point]]),
    )
    rep = reported(estimate_session(trials, EstimateOptions()))
    assert np.linalg.norm(rep.error) < 1e-9
    depth = 11.0 * spec_of("point").detector_floor[0] / 525.0 * 11.0 / 2.0  # ray angle, baseline
    assert np.sqrt(np.linalg.eigvalsh(rep.cov[0]).max()) == pytest.approx(depth, rel=0.5)


def test_frames_are_enough_once_another_would_not_shrink_the_measurement() -> None:
    """Still frames: enough at the least (3); frames scattered well beyond the floor: not
    until the next one's share falls under 5% (1 / (K + 1) of the scatter part); the dot's
    orientation (noise) is not read."""
    rng = np.random.default_rng(3)
    floor = (0.1, 0.08)
    still = np.tile([320.0, 240.0], (3, 1))
    assert not enough_frames(still[:2], np.zeros(2), floor)
    assert enough_frames(still, np.zeros(3), floor)
    noisy = [320.0, 240.0] + 0.3 * rng.standard_normal((40, 2))
    thetas = 0.05 * rng.standard_normal(40)
    needed = next(k for k in range(3, 41) if enough_frames(noisy[:k], thetas[:k], floor))
    assert 6 <= needed <= 30
    S = np.var(noisy[:needed], axis=0, ddof=1)
    left = S / needed + floor[0] ** 2
    assert np.all(S / (needed * (needed + 1)) <= 0.05 * left)
    spun = rng.uniform(-90, 90, 40)  # a round dot's blob orientation
    assert not enough_frames(still[:3].repeat(2, 0), spun[:6], (0.05, 0.0))
    assert enough_frames(still[:3].repeat(2, 0), None, (0.05, 0.0))


def test_nees_uses_the_non_degenerate_directions_only() -> None:
    cov = np.array([np.diag([1.0, 0.0, 4.0]), np.diag([1.0, 1.0, 1.0])])
    err = np.array([[1.0, 0.0, 2.0], [1.0, 1.0, 1.0]])
    score, dof = nees(err, cov)
    np.testing.assert_allclose(score, [2.0, 3.0])
    assert dof.tolist() == [2, 3]
    s_nan, d_nan = nees(np.array([[np.nan, 0, 0]]), np.eye(3)[None])
    assert np.isnan(s_nan[0])
    assert d_nan[0] == 0


def test_a_rank_2_region_gets_the_2_dof_semi_axis() -> None:
    # A ground point: its height is the ground's, so its region has two dimensions and is
    # judged by chi-square's 2-dof quantile (5.99), not the 3-dof one (7.81) (issue 46).
    rot = np.linalg.qr(np.random.default_rng(3).standard_normal((3, 3)))[0]
    flat = rot @ np.diag([0.0, 0.04, 0.25]) @ rot.T
    cov = np.stack([flat, np.diag([0.04, 0.01, 0.25]), np.zeros((3, 3)), np.full((3, 3), np.nan)])
    assert region_dof(cov).tolist() == [2, 3, 0, 0]
    expected = [np.sqrt(5.991464547107979 * 0.25), np.sqrt(7.814727903251178 * 0.25), 0.0]
    np.testing.assert_allclose(semiaxis95(cov)[:3], expected, rtol=1e-9)
    assert np.isnan(semiaxis95(cov)[3])
    # The trial columns read the same rule, whether or not a truth is known.
    for error in (np.zeros((4, 3)), np.full((4, 3), np.nan)):
        cols = uncertainty_columns(error, cov)
        np.testing.assert_allclose(cols["semiaxis95"][:3], expected, rtol=1e-9)


def test_dominant_input_sums_over_poses() -> None:
    v = np.zeros((2, 2, 5))
    v[0, :, 1] = [0.3, 0.3]  # x of both poses
    v[0, 0, 0] = 0.4  # pixels of one pose
    v[1, 1, 3] = 1.0
    names, share = dominant_input(v)
    assert names == [INPUT_GROUPS[1], "z translation"]
    np.testing.assert_allclose(share, [0.6, 1.0])
    names0, share0 = dominant_input(np.zeros((1, 2, 5)))
    assert names0 == [""]
    assert np.isnan(share0[0])


# --------------------------------------------------------------------------- calibration


def _thesis_geometry(rng: np.random.Generator, T: int) -> tuple[F64, F64]:
    """Typed poses (T, 2, 9 inputs without pixels) and truth points (T, 3) near Appendix D."""
    truth = np.column_stack(
        [rng.uniform(-1, 3, T), rng.uniform(-2, 1, T), rng.uniform(7.5, 10.5, T)]
    )
    t1 = np.column_stack([rng.uniform(-2, 0, T), np.zeros(T), rng.uniform(-1, 0, T)])
    t2 = t1 + np.column_stack([rng.uniform(1, 2.5, T), np.zeros(T), rng.uniform(-0.5, 0.5, T)])
    return np.stack([t1, t2], axis=1), truth


def _project(point: F64, t: F64) -> F64:
    P = projection_matrices(FOCAL, np.eye(3), t)
    X = np.concatenate([point, np.ones((point.shape[0], 1))], axis=1)
    y = np.einsum("tnij,tj->tni", P, X)
    return np.asarray(y[..., :2] / y[..., 2:3])


@pytest.mark.parametrize(("sigma_t", "sigma_px"), [(0.1, 0.05), (0.01, 0.5), (0.0625, 0.3)])
def test_point_covariance_is_calibrated_against_monte_carlo(
    sigma_t: float, sigma_px: float
) -> None:
    """Typed-pose and pixel noise as the recorder promises: 95% ellipsoids hold the truth
    95% of the time and NEES averages 3 (3000 trials, so +-0.1 and +-1% are tight)."""
    rng = np.random.default_rng(7)
    T = 3000
    t_true, truth = _thesis_geometry(rng, T)
    px = _project(truth, t_true) + sigma_px * rng.standard_normal((T, 2, 2))
    t_typed = t_true + sigma_t * rng.standard_normal((T, 2, 3))
    x = np.zeros((T, 2, 9))
    x[..., :2], x[..., 2], x[..., 3:6] = px, np.nan, t_typed
    C = np.zeros((T, 2, 9, 9))
    C[..., 0, 0] = C[..., 1, 1] = sigma_px**2
    for k in (3, 4, 5):
        C[..., k, k] = sigma_t**2

    def estimate(inp: F64) -> F64:
        P = projection_matrices(FOCAL, rotation_from_angles_deg(inp[..., 6:9]), inp[..., 3:6])
        return triangulate_points(inp[..., :2], P).point_grid

    out = propagate(estimate, x, C)
    score, dof = nees(estimate(x) - truth, out.cov_grid)
    assert (dof == 3).all()
    assert abs(score.mean() - 3.0) < 0.3
    assert 0.93 <= np.mean(score <= CHI2_95[3]) <= 0.97


def test_ground_covariance_is_calibrated_and_flat_in_height() -> None:
    rng = np.random.default_rng(11)
    T, h, sigma_t, sigma_px, sigma_th = 3000, 9.625, 0.05, 0.2, 0.3
    t_true, _ = _thesis_geometry(rng, T)
    ground = np.column_stack([rng.uniform(0, 3, T), np.full(T, h), rng.uniform(7, 10, T)])
    tip = ground + np.column_stack(
        [rng.uniform(-2, 2, T), -np.full(T, 6.0), rng.uniform(-4, -2, T)]
    )
    a, b = _project(tip, t_true), _project(ground, t_true)
    theta = np.degrees(np.arctan2(b[..., 1] - a[..., 1], b[..., 0] - a[..., 0]))
    x = np.zeros((T, 2, 9))
    x[..., :2] = a + sigma_px * rng.standard_normal((T, 2, 2))
    x[..., 2] = theta + sigma_th * rng.standard_normal((T, 2))
    x[..., 3:6] = t_true + sigma_t * rng.standard_normal((T, 2, 3))
    C = np.zeros((T, 2, 9, 9))
    C[..., 0, 0] = C[..., 1, 1] = sigma_px**2
    C[..., 2, 2] = sigma_th**2
    for k in (3, 4, 5):
        C[..., k, k] = sigma_t**2

    def estimate(inp: F64) -> F64:
        P = projection_matrices(FOCAL, np.eye(3), inp[..., 3:6])
        lines = image_lines(inp[..., :2], inp[..., 2])
        return triangulate_ground(lines, P, [0.0, 1.0, 0.0], h).point_grid

    est = estimate(x)
    out = propagate(estimate, x, C)
    assert np.abs(out.cov_grid[:, 1, :]).max() < 1e-9  # the ground fixes the height
    score, dof = nees(est - ground, out.cov_grid)
    good = np.isfinite(score)
    assert good.mean() > 0.99
    assert (dof[good] == 2).all()
    assert abs(score[good].mean() - 2.0) < 0.2
    assert abs(np.median(score[good]) - 1.386) < 0.15  # chi-square(2) median
    assert 0.93 <= np.mean(score[good] <= CHI2_95[2]) <= 0.97
