"""twopose.estimate directly: seeded synthetic truth projected into typed poses, through
measure() and estimate_trials(), for every method; degenerate trials flagged, not solved."""

from __future__ import annotations

import numpy as np
import pytest

from twopose.camera import Intrinsics, project_points, rotation_from_angles_deg
from twopose.estimate import EstimateOptions, PoseView, estimate_trials, measure
from twopose.methods import spec_of

INTRINSICS = Intrinsics(640, 480, 525.0, 525.0, 320.0, 240.0)
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


@pytest.mark.parametrize("method", ["point", "line", "ground"])
def test_every_method_recovers_seeded_truth(method: str) -> None:
    rng = np.random.default_rng(7)
    views, truth = _trials(method, rng, [1.0, 1.5, 2.0, 3.0])
    options = EstimateOptions()
    measurements, complete, detected = measure(views, options)
    assert complete.all()
    assert detected.all()
    ground = GROUND if spec_of(method).needs_ground else None
    est = estimate_trials(method, views, measurements, complete, detected, truth, ground, options)
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
    options = EstimateOptions()
    measurements, complete, detected = measure(views, options)
    ground = GROUND if spec_of(method).needs_ground else None
    est = estimate_trials(method, views, measurements, complete, detected, truth, ground, options)
    assert est.status[0] == "ok"
    assert est.status[1] == "degenerate"
    assert "no baseline" in str(est.reason[1])


def test_a_trial_with_one_pose_is_incomplete() -> None:
    rng = np.random.default_rng(9)
    views, truth = _trials("point", rng, [2.0, 2.0])
    views[1] = views[1][:1]
    options = EstimateOptions()
    measurements, complete, detected = measure(views, options)
    assert list(complete) == [True, False]
    est = estimate_trials("point", views, measurements, complete, detected, truth, None, options)
    assert est.status[0] == "ok"
    assert est.status[1] == "incomplete"
    assert not np.isfinite(est.point[1]).any()
