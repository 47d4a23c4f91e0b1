"""Solvers: thesis equations by hand, exact recovery of projected truth, degenerate statuses."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import assume, given, settings
from hypothesis import strategies as st

from twopose.camera.model import Intrinsics, project_points, rotation_from_angles_deg
from twopose.errors import InputValueError
from twopose.solve.nview import (
    NViewLines,
    NViewPoints,
    image_lines,
    projection_matrices,
    triangulate_ground,
    triangulate_lines,
    triangulate_points,
)

F = 525.0
INTR = Intrinsics(width=640, height=480, fx=F, fy=F, cx=320.0, cy=240.0)
K4 = np.array([F, F, 320.0, 240.0])


# The thesis' two-view forms, through the N-view solvers (two views: eq. 7-8, 14-15, 19).
def solve_point(px: np.ndarray, k: np.ndarray, R: np.ndarray, t: np.ndarray) -> NViewPoints:
    return triangulate_points(px, projection_matrices(k, R, t))


def solve_line(
    px: np.ndarray, th: np.ndarray, k: np.ndarray, R: np.ndarray, t: np.ndarray
) -> NViewLines:
    return triangulate_lines(image_lines(px, th), projection_matrices(k, R, t))


def solve_ground(
    px: np.ndarray, th: np.ndarray, k: np.ndarray, R: np.ndarray, t: np.ndarray, n: object, h: float
) -> NViewPoints:
    return triangulate_ground(image_lines(px, th), projection_matrices(k, R, t), n, h)  # type: ignore[arg-type]


def _batch(*views: tuple[np.ndarray, np.ndarray]) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    R = np.stack([v[0] for v in views])[None]
    t = np.stack([v[1] for v in views])[None]
    k = np.tile(K4, (1, len(views), 1))
    return k, R, t


def _line_obs(
    p0: np.ndarray, p1: np.ndarray, R: np.ndarray, t: np.ndarray
) -> tuple[np.ndarray, float]:
    a, b = project_points(np.stack([p0, p1]), INTR, R, t)
    d = b - a
    return a, float(np.degrees(np.arctan2(d[1], d[0])))


# ----------------------------------------------------------------- the thesis, literally


def thesis_point(px1, px2, R, d, f=F):
    """Eq. (5)-(8) in camera 1's frame with the thesis' image vectors (u, v, f)."""
    pb1 = np.array([px1[0] - 320.0, px1[1] - 240.0, f])
    pb2 = np.array([px2[0] - 320.0, px2[1] - 240.0, f])
    A = np.column_stack([pb1, -R @ pb2])
    alpha = np.linalg.inv(A.T @ A) @ A.T @ d
    return (alpha[0] * pb1 + (alpha[1] * R @ pb2 + d)) / 2


def thesis_normal(px, theta_deg, f=F):
    t = np.radians(theta_deg)
    m = np.array([-np.sin(t), np.cos(t)])
    c = m @ (np.asarray(px) - [320.0, 240.0])
    return np.array([f * m[0], f * m[1], -c])


def thesis_line(n1, n2, R, d):
    """Eq. (14)-(15) in camera 2's frame."""
    n12 = R.T @ n1
    u2 = np.cross(n2, n12) / np.linalg.norm(np.cross(n2, n12))
    A0 = np.stack([n2, n1 @ R, u2])
    return np.linalg.solve(A0, [0.0, -n1 @ d, 0.0]), u2


def thesis_ground(n1, n2, R, d, n3, h):
    """Eq. (19) in camera 2's frame."""
    A = np.stack([n2, n1 @ R, n3])
    return np.linalg.solve(A, [0.0, -n1 @ d, h])


def test_point_by_hand_simple_numbers() -> None:
    # Target 10 in straight ahead; the camera moves 1 in right: the dot moves 52.5 px left.
    k, R, t = _batch((np.eye(3), np.zeros(3)), (np.eye(3), np.array([1.0, 0.0, 0.0])))
    sol = solve_point(np.array([[[320.0, 240.0], [267.5, 240.0]]]), k, R, t)
    np.testing.assert_allclose(sol.point_grid[0], [0.0, 0.0, 10.0], atol=1e-12)
    assert sol.status[0] == "ok"
    assert sol.conditioning[0] == pytest.approx(np.sin(np.arctan(0.1)))


def test_point_matches_thesis_eq7_in_appendix_d_geometry() -> None:
    # Appendix D: camera 2 displaced 1.1 in along x; the thesis' target (1.91, 9.625, 8.375).
    target = np.array([1.91, 9.625, 8.375])
    c2 = np.array([1.1, 0.0, 0.0])
    px1 = project_points(target, INTR, np.eye(3), np.zeros(3))[0] + [0.3, -0.2]  # noisy pixels
    px2 = project_points(target, INTR, np.eye(3), c2)[0] + [-0.1, 0.4]
    k, R, t = _batch((np.eye(3), np.zeros(3)), (np.eye(3), c2))
    ours = solve_point(np.array([[px1, px2]]), k, R, t).point_grid[0]
    # Camera 1 is the grid frame here, so the thesis' p^1 is directly comparable.
    np.testing.assert_allclose(ours, thesis_point(px1, px2, np.eye(3), c2), atol=1e-10)


def test_line_and_ground_match_thesis_eq15_and_eq19_with_rotation() -> None:
    a, b = np.array([2.3, 3.6, 12.1]), np.array([1.91, 9.625, 8.375])
    R2 = rotation_from_angles_deg([3.0, -7.0, 2.0])
    c2 = np.array([1.5, 0.2, -0.75])
    (pa1, th1), (pa2, th2) = _line_obs(a, b, np.eye(3), np.zeros(3)), _line_obs(a, b, R2, c2)
    th1 += 0.3  # a slightly wrong measurement: both must agree on the same wrong answer
    k, R, t = _batch((np.eye(3), np.zeros(3)), (R2, c2))
    px = np.array([[pa1, pa2]])
    thetas = np.array([[th1, th2]])
    line = solve_line(px, thetas, k, R, t)
    n1, n2 = thesis_normal(pa1, th1), thesis_normal(pa2, th2)
    # Pose 1 is the grid frame: R = R1^T R2 = R2 and d = R1^T (c2 - c1) = c2.
    p0_cam2, u2 = thesis_line(n1, n2, R2, c2)
    np.testing.assert_allclose(line.point_grid[0], R2 @ p0_cam2 + c2, atol=1e-9)
    assert abs(abs(line.direction_grid[0] @ (R2 @ u2)) - 1) < 1e-12
    h = 9.625
    ground = solve_ground(px, thetas, k, R, t, [0.0, 1.0, 0.0], h)
    n3_cam2 = R2.T @ [0.0, 1.0, 0.0]
    p_cam2 = thesis_ground(n1, n2, R2, c2, n3_cam2, h - c2[1])
    np.testing.assert_allclose(ground.point_grid[0], R2 @ p_cam2 + c2, atol=1e-9)


def test_back_projected_plane_contains_the_line() -> None:
    a, b = np.array([1.0, 2.0, 10.0]), np.array([-1.0, 3.0, 14.0])
    pa, theta = _line_obs(a, b, np.eye(3), np.zeros(3))
    P = projection_matrices(K4, np.eye(3), np.zeros(3))
    plane = P.T @ image_lines(pa, theta)
    assert abs(plane @ [*a, 1.0]) < 1e-9 * np.linalg.norm(plane) * 10
    assert abs(plane @ [*b, 1.0]) < 1e-9 * np.linalg.norm(plane) * 14
    # theta and theta + 180 are the same line: the same plane up to scale.
    other = P.T @ image_lines(pa, theta + 180.0)
    assert np.linalg.norm(np.cross(other[:3], plane[:3])) < 1e-9 * np.linalg.norm(plane[:3]) ** 2


def test_projection_matrix_projects_like_the_camera_model() -> None:
    R = rotation_from_angles_deg([5.0, -3.0, 2.0])
    t = np.array([1.0, -0.5, 2.0])
    x = np.array([0.3, 1.2, 11.0])
    y = projection_matrices(K4, R, t) @ [*x, 1.0]
    np.testing.assert_allclose(y[:2] / y[2], project_points(x, INTR, R, t)[0], atol=1e-10)


# ----------------------------------------------------------------- exact recovery


coord = st.floats(-3.0, 3.0, allow_nan=False)
angle = st.floats(-20.0, 20.0, allow_nan=False)
pose = st.tuples(st.tuples(angle, angle, angle), st.tuples(coord, coord, coord))


def _view(
    p: tuple[tuple[float, float, float], tuple[float, float, float]],
) -> tuple[np.ndarray, np.ndarray]:
    return rotation_from_angles_deg(p[0]), np.array(p[1])


def _in_front(points: np.ndarray, R: np.ndarray, t: np.ndarray) -> bool:
    return bool(np.all(((points - t) @ R)[:, 2] > 1.0))


@settings(max_examples=150, deadline=None)
@given(pose, pose, st.tuples(coord, coord, st.floats(6.0, 20.0)))
def test_point_recovered_exactly(p1, p2, target) -> None:
    v1, v2 = _view(p1), _view(p2)
    x = np.array(target)
    assume(_in_front(x[None], *v1) and _in_front(x[None], *v2))
    px = np.stack([project_points(x, INTR, *v1)[0], project_points(x, INTR, *v2)[0]])[None]
    k, R, t = _batch(v1, v2)
    sol = solve_point(px, k, R, t)
    assume(sol.conditioning[0] > 1e-3)
    assert sol.status[0] == "ok"
    np.testing.assert_allclose(sol.point_grid[0], x, atol=float(1e-9 * np.linalg.norm(x)))
    assert sol.rms_px[0] < 1e-6


@settings(max_examples=150, deadline=None)
@given(
    pose,
    pose,
    st.tuples(coord, coord, st.floats(6.0, 20.0)),
    st.tuples(st.floats(-1, 1), st.floats(-1, 1), st.floats(-1, 1)),
)
def test_line_and_ground_point_recovered_exactly(p1, p2, anchor, direction) -> None:
    v1, v2 = _view(p1), _view(p2)
    u = np.array(direction)
    assume(np.linalg.norm(u) > 0.3)
    u /= np.linalg.norm(u)
    a = np.array(anchor)
    b = a + 2.0 * u
    assume(_in_front(np.stack([a, b]), *v1) and _in_front(np.stack([a, b]), *v2))
    (pa1, th1), (pa2, th2) = _line_obs(a, b, *v1), _line_obs(a, b, *v2)
    assume(np.linalg.norm(project_points(b, INTR, *v1)[0] - pa1) > 5)
    assume(np.linalg.norm(project_points(b, INTR, *v2)[0] - pa2) > 5)
    k, R, t = _batch(v1, v2)
    px, th = np.array([[pa1, pa2]]), np.array([[th1, th2]])
    line = solve_line(px, th, k, R, t)
    assume(line.conditioning[0] > 1e-3)
    assert line.status[0] == "ok"
    scale = np.linalg.norm(a) + 1
    assert np.linalg.norm(np.cross(line.direction_grid[0], u)) < 1e-9 * scale
    off = line.point_grid[0] - a
    assert np.linalg.norm(off - (off @ u) * u) < 1e-9 * scale
    # The point is the one closest to camera 2's centre (eq. 15's third row).
    assert abs((line.point_grid[0] - v2[1]) @ u) < 1e-9 * scale
    # Method 2 with a ground plane the line crosses at a clear angle.
    normal = np.array([0.0, 1.0, 0.0])
    assume(abs(u @ normal) > 0.2)
    h = 9.625
    ground = solve_ground(px, th, k, R, t, normal, h)
    assume(ground.conditioning[0] > 1e-3)
    expected = a + (h - a[1]) / u[1] * u
    np.testing.assert_allclose(
        ground.point_grid[0], expected, atol=float(1e-9 * (np.linalg.norm(expected) + 1) * 10)
    )


def test_batched_rows_are_independent() -> None:
    rng = np.random.default_rng(3)
    T = 50
    targets = rng.uniform([-2, -1, 8], [2, 3, 14], (T, 3))
    c2 = np.column_stack([rng.uniform(1, 2, T), np.zeros(T), rng.uniform(-1, 1, T)])
    px = np.stack(
        [
            np.stack(
                [
                    project_points(x, INTR, np.eye(3), np.zeros(3))[0],
                    project_points(x, INTR, np.eye(3), c)[0],
                ]
            )
            for x, c in zip(targets, c2, strict=True)
        ]
    )
    px[7] = np.nan  # a trial without detection must not disturb the others
    k = np.tile(K4, (T, 2, 1))
    R = np.tile(np.eye(3), (T, 2, 1, 1))
    t = np.stack([np.zeros((T, 3)), c2], axis=1)
    sol = solve_point(px, k, R, t)
    assert sol.status[7] == "no_detection"
    assert np.isnan(sol.point_grid[7]).all()
    keep = np.arange(T) != 7
    np.testing.assert_allclose(sol.point_grid[keep], targets[keep], atol=1e-9)


# ----------------------------------------------------------------- degenerate geometry


def test_point_on_the_baseline_is_degenerate() -> None:
    k, R, t = _batch((np.eye(3), np.zeros(3)), (np.eye(3), np.array([0.0, 0.0, 2.0])))
    sol = solve_point(np.array([[[320.0, 240.0], [320.0, 240.0]]]), k, R, t)
    assert sol.status[0] == "degenerate"
    assert sol.reason[0] == "point on the baseline (rays parallel)"
    assert np.isnan(sol.point_grid[0]).all()


def test_pure_rotation_has_no_baseline() -> None:
    R2 = rotation_from_angles_deg([0.0, 10.0, 0.0])
    x = np.array([0.5, 0.2, 10.0])
    px = np.stack(
        [
            project_points(x, INTR, np.eye(3), np.zeros(3))[0],
            project_points(x, INTR, R2, np.zeros(3))[0],
        ]
    )
    k, R, t = _batch((np.eye(3), np.zeros(3)), (R2, np.zeros(3)))
    sol = solve_point(px[None], k, R, t)
    assert sol.status[0] == "degenerate"
    assert "no baseline" in sol.reason[0]


def test_point_behind_a_camera_is_flagged() -> None:
    # Rays that meet behind the cameras: the dot would have to be behind both.
    k, R, t = _batch((np.eye(3), np.zeros(3)), (np.eye(3), np.array([1.0, 0.0, 0.0])))
    sol = solve_point(np.array([[[320.0, 240.0], [372.5, 240.0]]]), k, R, t)
    assert sol.status[0] == "degenerate"
    assert sol.reason[0] == "point behind a camera"


def test_line_coplanar_with_the_baseline_is_degenerate() -> None:
    a, b = np.array([0.0, 1.0, 10.0]), np.array([3.0, 1.0, 10.0])  # parallel to the x baseline
    c2 = np.array([1.0, 0.0, 0.0])
    (pa1, th1), (pa2, th2) = _line_obs(a, b, np.eye(3), np.zeros(3)), _line_obs(a, b, np.eye(3), c2)
    k, R, t = _batch((np.eye(3), np.zeros(3)), (np.eye(3), c2))
    px, th = np.array([[pa1, pa2]]), np.array([[th1, th2]])
    line = solve_line(px, th, k, R, t)
    assert line.status[0] == "degenerate"
    assert line.reason[0] == "line coplanar with the baseline"
    ground = solve_ground(px, th, k, R, t, [0, 1, 0], 9.625)
    assert ground.reason[0] == "line coplanar with the baseline"


def test_line_parallel_to_the_ground_is_degenerate_for_method_2() -> None:
    a, b = np.array([0.0, 2.0, 10.0]), np.array([1.0, 2.0, 13.0])  # horizontal
    c2 = np.array([1.5, 0.0, 0.0])
    (pa1, th1), (pa2, th2) = _line_obs(a, b, np.eye(3), np.zeros(3)), _line_obs(a, b, np.eye(3), c2)
    k, R, t = _batch((np.eye(3), np.zeros(3)), (np.eye(3), c2))
    px, th = np.array([[pa1, pa2]]), np.array([[th1, th2]])
    assert solve_line(px, th, k, R, t).status[0] == "ok"
    ground = solve_ground(px, th, k, R, t, [0, 1, 0], 9.625)
    assert ground.status[0] == "degenerate"
    assert ground.reason[0] == "line parallel to the ground"
    assert np.isnan(ground.point_grid[0]).all()


def test_wrong_shapes_and_estimators_are_input_errors() -> None:
    with pytest.raises(InputValueError, match="P"):
        triangulate_points(np.zeros((1, 3, 2)), np.zeros((1, 2, 3, 4)))
    with pytest.raises(InputValueError, match="estimator"):
        triangulate_points(np.zeros((1, 2, 2)), np.zeros((1, 2, 3, 4)), estimator="magic")
