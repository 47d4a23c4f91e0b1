"""twopose.solve.estimate directly: the padded batch, each method's solver on exact projections of
a seeded truth, the thesis estimate used for propagation, the margins and the input
covariance's layout. (A whole session through it: test_session_estimate.py.)"""

from __future__ import annotations

import numpy as np
import pytest

from twopose.camera.model import Intrinsics, project_points, rotation_from_angles_deg
from twopose.methods.specs import Method
from twopose.solve.estimate import (
    EstimateOptions,
    PoseView,
    ViewBatch,
    across_line_sigma_px,
    degrees_from_sine,
    input_covariance,
    margin_warnings,
    measure,
    nearest_on_line,
    shared_intrinsics,
    solve_batch,
    thesis_estimate,
)
from twopose.uncertainty.propagate import INPUTS_PER_VIEW, SHARED_INPUTS

INTRINSICS = Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0)
K = np.array([INTRINSICS.fx, INTRINSICS.fy, INTRINSICS.cx, INTRINSICS.cy])
OPTIONS = EstimateOptions()
GROUND = (np.array([0.0, 1.0, 0.0]), 9.625)  # y = h, y down (the thesis' ground)
POSES = np.array([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [2.0, 0.0, -3.0]])  # typed centres, inches


def _px(p: np.ndarray, t: np.ndarray) -> np.ndarray:
    out: np.ndarray = project_points(p[None], INTRINSICS, rotation_from_angles_deg([0, 0, 0]), t)
    return out[0]


def _view(
    t: np.ndarray,
    px: np.ndarray,
    theta: float = 0.0,
    *,
    frames: int = 5,
    found: bool = True,
    camera_id: str = "",
    intrinsics_sigma: np.ndarray | None = None,
) -> PoseView:
    return PoseView(
        pose=0,
        intrinsics=K.copy(),
        width_height=(640, 480),
        t_grid=t,
        r_deg=np.zeros(3),
        t_sigma=0.0625,
        r_sigma_deg=0.5,
        centroids=np.tile(px, (frames, 1)),
        thetas=np.full(frames, theta),
        found=np.full(frames, found),
        camera_id=camera_id,
        intrinsics_sigma=np.zeros(4) if intrinsics_sigma is None else intrinsics_sigma,
    )


def _line_view(t: np.ndarray, a: np.ndarray, b: np.ndarray) -> PoseView:
    pa, pb = _px(a, t), _px(b, t)
    theta = float(np.degrees(np.arctan2(pb[1] - pa[1], pb[0] - pa[0])))
    return _view(t, (pa + pb) / 2, theta)


def _batch(views: list[list[PoseView]]) -> ViewBatch:
    measurements, complete, detected = measure(views, OPTIONS)
    assert complete.all()
    assert detected.all()
    return ViewBatch.of(measurements, views)


def test_measure_flags_a_trial_of_one_pose_and_a_pose_that_saw_nothing() -> None:
    p = np.array([1.0, 2.0, 30.0])
    views = [
        [_view(POSES[0], _px(p, POSES[0]))],
        [_view(POSES[0], _px(p, POSES[0])), _view(POSES[1], _px(p, POSES[1]), found=False)],
        [_view(POSES[0], _px(p, POSES[0])), _view(POSES[1], _px(p, POSES[1]))],
    ]
    measurements, complete, detected = measure(views, OPTIONS)
    assert complete.tolist() == [False, True, True]
    assert detected.tolist() == [False, False, True]
    assert measurements[0] == []
    assert measurements[2][1].n_used == 5


def test_the_batch_pads_short_rows_with_exact_views_that_are_not_valid() -> None:
    p = np.array([1.0, 2.0, 30.0])
    views = [
        [_view(t, _px(p, t)) for t in POSES[:2]],
        [_view(t, _px(p, t)) for t in POSES],
    ]
    batch = _batch(views)
    assert batch.inputs.shape == (2, 3, len(INPUTS_PER_VIEW))
    assert batch.valid.tolist() == [[True, True, False], [True, True, True]]
    assert np.isnan(batch.inputs[0, 2, :3]).all()
    np.testing.assert_array_equal(batch.intrinsics[0, 2], [1.0, 1.0, 0.0, 0.0])
    np.testing.assert_allclose(batch.inputs[1, 2, 3:6], POSES[2])
    np.testing.assert_allclose(batch.inputs[1, 1, :2], _px(p, POSES[1]))
    assert batch.P().shape == (2, 3, 3, 4)


def test_each_solver_recovers_a_seeded_truth_from_exact_projections() -> None:
    rng = np.random.default_rng(3)
    truths = rng.uniform([-4, -2, 25], [4, 2, 40], size=(4, 3))
    batch = _batch([[_view(t, _px(p, t)) for t in POSES] for p in truths])
    solved = solve_batch(Method.POINT, batch, None, OPTIONS)
    assert (solved.status == "ok").all()
    np.testing.assert_allclose(solved.point, truths, atol=1e-9)
    assert solved.optimal is not None
    np.testing.assert_allclose(solved.optimal, truths, atol=1e-9)
    assert (solved.margins["parallax_deg"] > 1.0).all()

    a, b = truths, truths + rng.normal(size=(4, 3)) * [3, 3, 1]
    lines = solve_batch(
        Method.LINE,
        _batch([[_line_view(t, *ab) for t in POSES] for ab in zip(a, b, strict=True)]),
        None,
        OPTIONS,
    )
    assert lines.direction is not None
    d = (b - a) / np.linalg.norm(b - a, axis=1, keepdims=True)
    np.testing.assert_allclose(np.abs(np.einsum("ti,ti->t", lines.direction, d)), 1.0, atol=1e-9)
    off = nearest_on_line(lines.point, lines.direction, a) - a
    np.testing.assert_allclose(off, 0.0, atol=1e-7)
    assert set(lines.margins) == {"parallax_deg", "plane_angle_deg"}


def test_the_ground_solver_meets_the_ground_where_the_pointing_line_does() -> None:
    # A finger's line from above the ground down to its point on y = h.
    on_ground = np.array([[1.0, GROUND[1], 30.0], [-2.0, GROUND[1], 26.0]])
    above = on_ground + np.array([[0.5, -6.0, -2.0], [1.0, -5.0, 1.0]])
    views = [
        [_line_view(t, top, g) for t in POSES[:2]] for top, g in zip(above, on_ground, strict=True)
    ]
    solved = solve_batch(Method.GROUND, _batch(views), GROUND, OPTIONS)
    assert (solved.status == "ok").all()
    np.testing.assert_allclose(solved.point, on_ground, atol=1e-7)
    assert (solved.margins["line_plane_angle_deg"] > 10.0).all()


def test_a_trial_seen_twice_from_one_place_is_flagged_not_solved() -> None:
    p = np.array([1.0, 2.0, 30.0])
    batch = _batch([[_view(POSES[0], _px(p, POSES[0])), _view(POSES[0], _px(p, POSES[0]))]])
    solved = solve_batch(Method.POINT, batch, None, OPTIONS)
    assert solved.status[0] != "ok"
    assert solved.reason[0]


@pytest.mark.parametrize("method", [Method.POINT, Method.GROUND])
def test_the_thesis_estimate_of_unperturbed_inputs_is_the_solvers_answer(method: Method) -> None:
    on_ground = np.array([[1.0, GROUND[1], 30.0]])
    top = on_ground + np.array([0.5, -6.0, -2.0])
    if method is Method.POINT:
        views = [[_view(t, _px(on_ground[0], t)) for t in POSES]]
    else:
        views = [[_line_view(t, top[0], on_ground[0]) for t in POSES]]
    batch = _batch(views)
    estimate = thesis_estimate(method, batch, GROUND, OPTIONS, reference=on_ground)
    solved = solve_batch(method, batch, GROUND, OPTIONS)
    np.testing.assert_allclose(estimate(batch.inputs), solved.point, atol=1e-12)
    # Stacked copies (how propagation perturbs) give one answer per copy.
    stacked = np.concatenate([batch.inputs, batch.inputs])
    assert estimate(stacked).shape == (2, 3)


def test_degrees_from_sine_clips_and_keeps_nan() -> None:
    out = degrees_from_sine(np.array([0.0, 0.5, 1.2, -0.1, np.nan]))
    np.testing.assert_allclose(out[:4], [0.0, 30.0, 90.0, 0.0])
    assert np.isnan(out[4])


def test_margin_warnings_name_each_margin_under_its_limit_on_ok_trials_only() -> None:
    status = np.array(["ok", "ok", "degenerate"])
    margins = {
        "parallax_deg": np.array([0.5, 3.0, 0.1]),
        "plane_angle_deg": np.array([2.0, 20.0, 0.1]),
    }
    notes = margin_warnings(status, margins, OPTIONS)
    assert notes == ["ray parallax 0.50 deg < 1; plane angle 2.00 deg < 5", "", ""]


def test_input_covariance_holds_pixels_then_the_typed_poses_resolution() -> None:
    rng = np.random.default_rng(5)
    p = np.array([1.0, 2.0, 30.0])
    views = [[_view(t, _px(p, t)) for t in POSES[:2]], [_view(t, _px(p, t)) for t in POSES]]
    for row in views:
        for v in row:
            v.centroids[:] += 0.3 * rng.standard_normal(v.centroids.shape)
    measurements, _, _ = measure(views, OPTIONS)
    batch = ViewBatch.of(measurements, views)
    scatters = [[(np.eye(3) * 0.09, 4) for _ in row] for row in views]
    C = input_covariance(measurements, views, scatters, np.eye(3) * 0.09, batch, median=False)
    assert C.shape == (2, 3, 9, 9)
    np.testing.assert_allclose(C[1, 0, :3, :3], np.eye(3) * 0.09 / 5)  # the mean of 5 frames
    np.testing.assert_allclose(np.diag(C[1, 0])[3:6], 0.0625**2)
    np.testing.assert_allclose(np.diag(C[1, 0])[6:9], 0.5**2)
    assert not C[0, 2].any()  # padding: no uncertainty
    median = input_covariance(measurements, views, scatters, np.eye(3) * 0.09, batch, median=True)
    np.testing.assert_allclose(median[1, 0, :3, :3], C[1, 0, :3, :3] * np.pi / 2)


def test_shared_intrinsics_group_a_trials_views_by_camera() -> None:
    p = np.array([1.0, 2.0, 30.0])
    exact = [[_view(t, _px(p, t)) for t in POSES]]
    assert shared_intrinsics(exact, _batch(exact)) is None  # no calibration sigma: exact
    sigma = np.array([0.9, 1.0, 1.1, 1.2])
    views = [
        [
            _view(POSES[0], _px(p, POSES[0]), camera_id="left", intrinsics_sigma=sigma),
            _view(POSES[1], _px(p, POSES[1]), camera_id="right", intrinsics_sigma=2 * sigma),
            _view(POSES[2], _px(p, POSES[2]), camera_id="left", intrinsics_sigma=sigma),
        ]
    ]
    shared = shared_intrinsics(views, _batch(views))
    assert shared is not None
    assert shared.group.tolist() == [[0, 1, 0]]
    assert shared.cov.shape == (1, 2, len(SHARED_INPUTS), len(SHARED_INPUTS))
    np.testing.assert_allclose(np.diag(shared.cov[0, 1]), (2 * sigma) ** 2)


def test_the_across_line_sigma_is_the_pixel_sigma_normal_to_the_line() -> None:
    cov = np.zeros((1, 2, 9, 9))
    cov[0, :, 0, 0], cov[0, :, 1, 1] = 4.0, 0.25  # sigma 2 px along x, 0.5 px along y
    # A horizontal line (0 deg) is crossed along y; a vertical one (90 deg) along x.
    np.testing.assert_allclose(across_line_sigma_px(np.array([[0.0, 90.0]]), cov), [[0.5, 2.0]])
    # An undefined variance becomes 1 px rather than NaN (the fit's weight stays finite).
    assert across_line_sigma_px(np.array([[0.0, 0.0]]), np.zeros((1, 2, 9, 9)))[0, 0] == 1.0
