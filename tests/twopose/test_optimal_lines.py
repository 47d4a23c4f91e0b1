"""The reprojection-optimal line (twopose.solve.optimal_lines) on seeded synthetic lines: truth
recovered, never further from the segments than its algebraic start, a covariance that
covers the truth as often as it says."""

from __future__ import annotations

import numpy as np
import pytest

from twopose.camera.model import camera_centres, rotation_from_angles_deg
from twopose.errors import InputValueError
from twopose.solve.nview import projection_matrices, segment_lines, triangulate_lines
from twopose.solve.optimal_lines import centroid_segments, endpoint_distances, optimal_lines

K4 = np.array([525.0, 520.0, 318.0, 242.0])
CHI2_4_95 = 9.4877  # chi-square, 4 degrees of freedom, 95%


def _scene(
    rng: np.random.Generator, T: int, depths: list[float]
) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Cameras at the given z (one per view, scattered in x and y), lines 2 units long
    near z = 10, none pointing at a camera: (P, exact segments (T, N, 4), a point and
    unit direction of each line)."""
    N = len(depths)
    R = rotation_from_angles_deg(rng.uniform(-5, 5, (T, N, 3)))
    t = np.zeros((T, N, 3))
    t[..., 0], t[..., 1] = rng.uniform(-3, 3, (T, N)), rng.uniform(-1, 1, (T, N))
    t[..., 2] = np.array(depths) + rng.uniform(-0.5, 0.5, (T, N))
    P = projection_matrices(np.tile(K4, (T, N, 1)), R, t)
    a = np.column_stack([rng.uniform(-1, 1, T), rng.uniform(-1, 1, T), rng.uniform(9, 11, T)])
    u = rng.normal(size=(T, 3))
    u[:, 2] *= 0.5  # mostly across the view: no camera sees a line end-on
    u /= np.linalg.norm(u, axis=1, keepdims=True)

    def project(X: np.ndarray) -> np.ndarray:
        y = np.einsum("tnij,tj->tni", P, np.concatenate([X, np.ones((T, 1))], axis=1))
        return np.asarray(y[..., :2] / y[..., 2:])

    # Each view sees its own stretch of the line.
    s0, s1 = rng.uniform(-1.0, -0.3, (T, N)), rng.uniform(0.3, 1.0, (T, N))
    seg = np.empty((T, N, 4))
    for j in range(N):
        ends = [project(a + s[:, j, None] * u)[:, j] for s in (s0, s1)]
        seg[:, j] = np.concatenate(ends, axis=1)
    return P, seg, a, u


def _noisy(rng: np.random.Generator, seg: np.ndarray, sigma: np.ndarray) -> np.ndarray:
    """Each endpoint moved across its segment by N(0, sigma of its view)."""
    d = seg[..., 2:] - seg[..., :2]
    n = np.stack([-d[..., 1], d[..., 0]], -1) / np.linalg.norm(d, axis=-1, keepdims=True)
    out = seg.copy()
    out[..., :2] += (sigma * rng.standard_normal(sigma.shape))[..., None] * n
    out[..., 2:] += (sigma * rng.standard_normal(sigma.shape))[..., None] * n
    return out


def _angle_deg(v: np.ndarray, u: np.ndarray) -> np.ndarray:
    return np.asarray(np.degrees(np.arcsin(np.clip(np.linalg.norm(np.cross(v, u), axis=1), 0, 1))))


def _cost(
    x: np.ndarray, u: np.ndarray, seg: np.ndarray, P: np.ndarray, sigma: np.ndarray
) -> np.ndarray:
    return np.asarray(((endpoint_distances(x, u, seg, P) / sigma[..., None]) ** 2).sum((1, 2)))


@pytest.mark.parametrize("n_views", [3, 4, 6])
def test_exact_segments_give_the_true_line(n_views: int) -> None:
    rng = np.random.default_rng(n_views)
    P, seg, a, u = _scene(rng, 50, list(np.linspace(-4, 2, n_views)))
    fit = optimal_lines(seg, P)
    assert (fit.status == "ok").all()
    assert _angle_deg(fit.direction_grid, u).max() < 1e-6
    off = fit.point_grid - a
    across = off - (off * u).sum(1, keepdims=True) * u
    assert np.linalg.norm(across, axis=1).max() < 1e-7
    assert fit.rms_px.max() < 1e-6
    # The reported point is the line's point nearest the last camera, as triangulate_lines'.
    last = camera_centres(P)[:, -1]
    assert np.abs(((last - fit.point_grid) * fit.direction_grid).sum(1)).max() < 1e-6


def test_two_views_leave_the_algebraic_line() -> None:
    rng = np.random.default_rng(11)
    P, seg, _, _ = _scene(rng, 200, [0.0, -3.0])
    seg = _noisy(rng, seg, np.full((200, 2), 1.0))
    fit = optimal_lines(seg, P, sigma_px=np.full((200, 2), 1.0))
    start = triangulate_lines(segment_lines(seg), P)
    np.testing.assert_allclose(fit.direction_grid, start.direction_grid, atol=1e-9)
    np.testing.assert_allclose(fit.point_grid, start.point_grid, atol=1e-7)
    assert (fit.iterations == 0).all()
    assert fit.rms_px.max() < 1e-6
    assert np.isnan(fit.variance_factor).all()  # no redundancy
    assert np.isfinite(fit.cov).all()  # the a-priori covariance still holds


def test_noisy_lines_beat_their_algebraic_start() -> None:
    rng = np.random.default_rng(3)
    T = 2000
    P, exact, _, u = _scene(rng, T, [0.0, -8.0, 3.0, -2.0])  # views at 2-18 units
    sigma = np.tile([0.1, 0.1, 0.1, 1.0], (T, 1))  # one view's segments are noisier
    seg = _noisy(rng, exact, sigma)
    fit = optimal_lines(seg, P, sigma_px=sigma)
    thesis = triangulate_lines(segment_lines(seg), P)
    weighted = triangulate_lines(segment_lines(seg), P, estimator="weighted", sigma_px=sigma)
    assert (fit.status == "ok").all()
    # Maximum likelihood: never a larger weighted sum of squares than either algebraic line.
    cost = _cost(fit.point_grid, fit.direction_grid, seg, P, sigma)
    for other in (thesis, weighted):
        assert (cost <= _cost(other.point_grid, other.direction_grid, seg, P, sigma) + 1e-9).all()
    # And the truth, more closely than either.
    angle = np.median(_angle_deg(fit.direction_grid, u))
    assert angle < np.median(_angle_deg(weighted.direction_grid, u))
    assert angle < 0.5 * np.median(_angle_deg(thesis.direction_grid, u))
    # With equal weights the plain RMS never rises above the algebraic start's.
    even = optimal_lines(seg, P)
    assert (even.rms_px <= even.start_rms_px + 1e-12).all()
    assert np.median(even.rms_px) < np.median(even.start_rms_px)


def test_covariance_covers_the_truth_as_it_says() -> None:
    rng = np.random.default_rng(8)
    T = 2000
    P, exact, a, u = _scene(rng, T, [0.0, -8.0, 3.0, -2.0])
    sigma = np.tile([0.02, 0.02, 0.02, 0.2], (T, 1))  # small: first order holds
    seg = _noisy(rng, exact, sigma)
    fit = optimal_lines(seg, P, sigma_px=sigma)
    # The truth in the fit's terms: its point nearest the last camera, its direction signed.
    last = camera_centres(P)[:, -1]
    u = np.where(((u * fit.direction_grid).sum(1) < 0)[:, None], -u, u)
    x = a + ((last - a) * u).sum(1, keepdims=True) * u
    e = np.concatenate([fit.point_grid - x, fit.direction_grid - u], axis=1)
    nees = np.einsum("ti,tij,tj->t", e, np.linalg.pinv(fit.cov, rcond=1e-10, hermitian=True), e)
    assert 3.6 < nees.mean() < 4.8  # chi-square with 4 degrees of freedom: mean 4
    assert 0.92 < np.mean(nees < CHI2_4_95) < 0.98
    assert 0.9 < np.mean(fit.variance_factor) < 1.1
    # Without sigma_px: equal weights, the covariance scaled by the residuals' own variance.
    even = optimal_lines(seg[:50, :3], P[:50, :3])
    prior = optimal_lines(seg[:50, :3], P[:50, :3], sigma_px=np.ones((50, 3)))
    np.testing.assert_allclose(
        even.cov, even.variance_factor[:, None, None] * prior.cov, rtol=1e-6, atol=1e-18
    )


def test_missing_views_are_ignored_and_degenerate_rows_say_so() -> None:
    rng = np.random.default_rng(5)
    P, exact, _, _ = _scene(rng, 40, [0.0, -3.0, 2.0, -5.0])
    seg = _noisy(rng, exact, np.full((40, 4), 0.5))
    gap = seg.copy()
    gap[:, 2] = np.nan
    without = optimal_lines(gap, P)
    dropped = optimal_lines(seg[:, [0, 1, 3]], P[:, [0, 1, 3]])
    # The same problem, converged to the same line (within the refinement's tolerance).
    np.testing.assert_allclose(without.direction_grid, dropped.direction_grid, atol=1e-6)
    np.testing.assert_allclose(without.point_grid, dropped.point_grid, atol=1e-5)
    np.testing.assert_allclose(without.rms_px, dropped.rms_px, rtol=1e-9)
    one = seg.copy()
    one[:, 1:] = np.nan
    alone = optimal_lines(one, P)
    assert (alone.status == "no_detection").all()
    assert np.isnan(alone.point_grid).all()
    assert np.isnan(alone.cov).all()
    with pytest.raises(InputValueError, match="sigma_px"):
        optimal_lines(seg, P, sigma_px=np.zeros((40, 4)))
    with pytest.raises(InputValueError, match="segments must be"):
        optimal_lines(seg[..., :3], P)


def test_a_centroid_and_an_angle_as_their_equivalent_segment() -> None:
    seg, sigma = centroid_segments([[100.0, 50.0]], [90.0], [0.5], [0.25])
    h = 0.5 / np.deg2rad(0.25)  # the half-length at which sigma_across / h is the angle's
    np.testing.assert_allclose(seg, [[100.0, 50.0 - h, 100.0, 50.0 + h]], atol=1e-9)
    assert sigma[0] == pytest.approx(np.sqrt(2) * 0.5)
    exact, _ = centroid_segments([[0.0, 0.0]], [0.0], [1.0], [0.0])  # an exact angle
    assert exact[0, 2] == pytest.approx(1e4)
    # Two views: the line through both image lines, whatever the segments' lengths.
    rng = np.random.default_rng(2)
    P, seg4, _, _ = _scene(rng, 30, [0.0, -3.0])
    mid = 0.5 * (seg4[..., :2] + seg4[..., 2:])
    theta = np.degrees(np.arctan2(seg4[..., 3] - seg4[..., 1], seg4[..., 2] - seg4[..., 0]))
    seg, sigma = centroid_segments(mid, theta, np.full((30, 2), 0.3), np.full((30, 2), 0.1))
    fit = optimal_lines(seg, P, sigma_px=sigma)
    start = triangulate_lines(segment_lines(seg4), P)
    np.testing.assert_allclose(fit.direction_grid, start.direction_grid, atol=1e-8)


def test_a_zero_length_segment_or_a_tiny_sigma_is_no_crash() -> None:
    rng = np.random.default_rng(6)
    P, exact, _, _ = _scene(rng, 20, [0.0, -3.0, 2.0])
    seg = _noisy(rng, exact, np.full((20, 3), 0.5))
    point = seg.copy()
    point[:, 2, 2:] = point[:, 2, :2]  # view 3 saw a point: its image line is zero
    algebraic = triangulate_lines(segment_lines(point), P)
    two = triangulate_lines(segment_lines(seg[:, :2]), P[:, :2])
    np.testing.assert_allclose(algebraic.direction_grid, two.direction_grid, atol=1e-12)
    assert (optimal_lines(point, P).status == "ok").all()
    lone = point.copy()
    lone[:, 1, 2:] = lone[:, 1, :2]
    assert (triangulate_lines(segment_lines(lone), P).reason == "fewer than two views").all()
    sigma = np.ones((20, 3))
    sigma[:, 0] = 1e-300
    fit = optimal_lines(seg, P, sigma_px=sigma)  # weights 1e300: relative to the largest
    assert (fit.status == "ok").all()
    assert np.isfinite(fit.point_grid).all()
