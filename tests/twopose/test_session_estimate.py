"""twopose.session_estimate directly: seeded synthetic truth projected into typed poses,
through estimate_session() for every method; degenerate trials flagged, not solved; the
estimate never reads the truth (twopose.truth compares with it)."""

from __future__ import annotations

import numpy as np
import pytest

from twopose.camera import Intrinsics, project_points, rotation_from_angles_deg
from twopose.estimate import EstimateOptions, PoseView
from twopose.methods import Method, spec_of
from twopose.session_estimate import (
    SessionEstimate,
    SessionTrials,
    estimate_session,
    running_estimates,
)
from twopose.truth import reported

INTRINSICS = Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0)
H = 9.625  # the thesis' ground height: the ground plane y = h (y down)
GROUND = (np.array([0.0, 1.0, 0.0]), H)
FRAMES = 5


def _view(
    pose: int, t: np.ndarray, px: np.ndarray, theta: float, rng: np.random.Generator
) -> PoseView:
    """A pose seeing ``px`` (the target's centroid) with image orientation ``theta`` over
    FRAMES frames of 0.3 px noise."""
    return PoseView(
        pose=pose,
        intrinsics=np.array([INTRINSICS.fx, INTRINSICS.fy, INTRINSICS.cx, INTRINSICS.cy]),
        width_height=(640, 480),
        t_grid=t,
        r_deg=np.zeros(3),
        t_sigma=0.0625,
        r_sigma_deg=0.5,
        centroids=px + 0.3 * rng.standard_normal((FRAMES, 2)),
        thetas=np.full(FRAMES, theta) + 0.1 * rng.standard_normal(FRAMES),
        found=np.ones(FRAMES, dtype=bool),
    )


def _project(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    projected: np.ndarray = project_points(
        p[None], INTRINSICS, rotation_from_angles_deg([0, 0, 0]), t
    )
    return projected[0]


def _line_view(
    pose: int, t: np.ndarray, a: np.ndarray, b: np.ndarray, rng: np.random.Generator
) -> PoseView:
    """A pose seeing the 3-D segment a-b: its midpoint's image and the image direction."""
    pa, pb = _project(a, t), _project(b, t)
    theta = float(np.degrees(np.arctan2(pb[1] - pa[1], pb[0] - pa[0])))
    return _view(pose, t, (pa + pb) / 2, theta, rng)


def _trials(
    method: str, rng: np.random.Generator, baselines: list[float]
) -> tuple[list[list[PoseView]], np.ndarray]:
    """One trial per baseline (the second camera's x, in inches; 0: no baseline)."""
    views, truth = [], []
    for b in baselines:
        t1, t2 = np.zeros(3), np.array([b, 0.0, 0.0])
        if method == "point":
            p = np.array([0.5, 1.5, 11.0]) + rng.uniform(-0.5, 0.5, 3)
            row = [
                _view(1, t1, _project(p, t1), np.nan, rng),
                _view(2, t2, _project(p, t2), np.nan, rng),
            ]
            truth.append([p, [np.nan] * 3])
        else:
            g = np.array([1.9, H, 8.4]) + np.array(
                [rng.uniform(-0.5, 0.5), 0, rng.uniform(-0.5, 0.5)]
            )
            top = g + np.array([0.3, -6.0, 1.5])  # the finger, leaning towards the camera
            row = [_line_view(1, t1, top, g, rng), _line_view(2, t2, top, g, rng)]
            truth.append([top, g] if method == "line" else [g, [np.nan] * 3])
        views.append(row)
    return views, np.array(truth, dtype=np.float64)


def _estimate(method: str, views: list[list[PoseView]], truth: np.ndarray) -> SessionEstimate:
    trials = SessionTrials(
        method=Method(method),
        units="in",
        trial_ids=tuple(range(1, len(views) + 1)),
        views=views,
        truth=truth,
        ground=GROUND if spec_of(method).needs_ground else None,
    )
    return estimate_session(trials, EstimateOptions())


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
    covariance and warning the same (what is compared with the truth is twopose.truth's)."""
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


def test_a_line_is_reported_at_its_point_nearest_the_true_midpoint() -> None:
    """twopose.truth: the reported point lies on the estimated line, nearest the true
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


def test_running_estimates_use_the_first_frames_of_each_pose() -> None:
    views, truth = _trials("point", np.random.default_rng(12), [1.5, 2.5])
    estimate = _estimate("point", views, truth)
    keys, solved = running_estimates(estimate)
    assert keys == [(i, n) for i in range(2) for n in range(1, FRAMES + 1)]
    assert solved is not None
    # with every frame, the running estimate is the session's estimate
    last = [k for k, (_, n) in enumerate(keys) if n == FRAMES]
    np.testing.assert_allclose(solved.point[last], estimate.estimates.point)
