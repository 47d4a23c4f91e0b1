from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from twopose.camera.model import (
    Intrinsics,
    project_points,
    quaternion_xyzw_from_matrix,
    rotation_from_angles_deg,
)
from twopose.errors import InputValueError

angles = st.tuples(*(st.floats(-180, 180, allow_nan=False) for _ in range(3)))


def test_rotation_order_is_rx_ry_rz() -> None:
    R = rotation_from_angles_deg([90.0, 0.0, 0.0]) @ rotation_from_angles_deg([0.0, 90.0, 0.0])
    np.testing.assert_allclose(rotation_from_angles_deg([90.0, 90.0, 0.0]), R, atol=1e-12)
    # Rx(90) maps the camera's z (forward) to -y (up) in the grid frame.
    np.testing.assert_allclose(
        rotation_from_angles_deg([90, 0, 0]) @ [0, 0, 1], [0, -1, 0], atol=1e-12
    )


@given(angles)
def test_rotation_is_proper_orthonormal(a: tuple[float, float, float]) -> None:
    R = rotation_from_angles_deg(a)
    np.testing.assert_allclose(R @ R.T, np.eye(3), atol=1e-12)
    assert np.linalg.det(R) == pytest.approx(1.0)


@given(angles)
def test_quaternion_round_trip(a: tuple[float, float, float]) -> None:
    R = rotation_from_angles_deg(a)
    x, y, z, w = quaternion_xyzw_from_matrix(R)
    # Rotation matrix of the quaternion (x, y, z, w).
    Rq = np.array(
        [
            [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
            [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
            [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
        ]
    )
    np.testing.assert_allclose(Rq, R, atol=1e-9)
    assert w >= 0


def test_projection_matches_the_pinhole_equations() -> None:
    intr = Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0)
    # Thesis eq. 1-2: u = f x / z, v = f y / z, relative to the principal point.
    px = project_points([[1.0, 2.0, 10.0]], intr, np.eye(3), [0.0, 0.0, 0.0])
    np.testing.assert_allclose(px, [[320 + 52.5, 240 + 105.0]])
    # Moving the camera +1 in x moves the point 1 unit left in the camera frame.
    px2 = project_points([[1.0, 2.0, 10.0]], intr, np.eye(3), [1.0, 0.0, 0.0])
    np.testing.assert_allclose(px2, [[320.0, 240 + 105.0]])


def test_projection_behind_camera_is_nan() -> None:
    intr = Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0)
    assert np.isnan(project_points([[0.0, 0.0, -5.0]], intr, np.eye(3), [0, 0, 0])).all()


def test_projection_with_distortion_matches_opencv() -> None:
    import cv2

    intr = Intrinsics(
        width=640,
        height=480,
        fx=500.0,
        fy=510.0,
        cx=318.0,
        cy=242.0,
        distortion=(-0.2, 0.05, 0.001, -0.002, 0.01),
    )
    rng = np.random.default_rng(0)
    pts = rng.uniform([-3, -2, 8], [3, 2, 15], size=(20, 3))
    ours = project_points(pts, intr, np.eye(3), np.zeros(3))
    theirs, _ = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), intr.K, np.array(intr.distortion))
    np.testing.assert_allclose(ours, theirs.reshape(-1, 2), atol=1e-9)


@pytest.mark.parametrize(
    ("kwargs", "message"),
    [
        ({"width": 0}, "width must be a whole number > 0"),
        ({"width": 1e12}, "width must be a whole number > 0"),
        ({"fx": -1.0}, "fx must be positive"),
        ({"cy": float("inf")}, "cy must be finite"),
        ({"distortion": (0.1, 0.0)}, "distortion"),
    ],
)
def test_intrinsics_check_themselves(kwargs: dict[str, object], message: str) -> None:
    values = {"width": 640, "height": 480, "fx": 525.0, "fy": 525.0, "cx": 320.0, "cy": 240.0}
    with pytest.raises(InputValueError, match=message):
        Intrinsics(**(values | kwargs))  # type: ignore[arg-type]


def test_intrinsics_from_and_to_a_dict() -> None:
    intr = Intrinsics(
        width=320,
        height=240,
        fx=300.0,
        fy=301,
        cx=160.0,
        cy=120.0,
        distortion=(-0.1, 0.0, 0.0, 0.0, 0.0),
    )
    assert Intrinsics.from_dict(intr.to_dict(), "here") == intr
    assert isinstance(intr.fy, float)
    with pytest.raises(InputValueError, match="calibration x: missing cx, cy"):
        Intrinsics.from_dict({"width": 1, "height": 1, "fx": 1, "fy": 1}, "calibration x")
    with pytest.raises(InputValueError, match="calibration x: fx must be a number"):
        Intrinsics.from_dict(intr.to_dict() | {"fx": "big"}, "calibration x")


def test_a_pixels_ray_passes_through_the_point_it_sees() -> None:
    """twopose.camera.model.grid_rays, the one back-projection (the views table, the top view and
    the simulator's pixels read it): project points, back-project their pixels, and each
    ray from the camera centre meets its point."""
    from twopose.camera.model import grid_rays

    rng = np.random.default_rng(3)
    intr = Intrinsics(width=640, height=480, fx=525.0, fy=520.0, cx=318.0, cy=243.0)
    R = rotation_from_angles_deg([4.0, -7.0, 2.0])
    t = np.array([1.0, -0.5, -2.0])
    points = rng.uniform([-3, -2, 8], [3, 2, 15], (20, 3))
    px = project_points(points, intr, R, t)
    k = [intr.fx, intr.fy, intr.cx, intr.cy]
    rays = grid_rays(px, np.broadcast_to(k, (20, 4)), np.broadcast_to(R, (20, 3, 3)))
    to_points = points - t
    along = np.einsum("ij,ij->i", to_points, rays)
    np.testing.assert_allclose(rays * along[:, None], to_points, atol=1e-9)
    np.testing.assert_allclose(np.linalg.norm(rays, axis=1), 1.0)
