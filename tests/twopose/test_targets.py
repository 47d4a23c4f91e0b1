"""twopose.methods.targets directly: the finger's axis meets the ground where it is told to, its tip
at the given height above the ground, its base a finger's length behind, heading as the
azimuth says (180 degrees: back at the camera); a board's corners lie where its placement
says, in OpenCV's order, and a board that is no board is refused."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from twopose.errors import InputValueError
from twopose.methods.targets import BoardPlacement, finger_axis


@given(
    x=st.floats(-20, 20),
    z=st.floats(5, 40),
    h=st.floats(2, 15),
    tilt=st.floats(0, 70),
    azimuth=st.floats(-180, 180),
    tip_height=st.floats(1, 10),
    length=st.floats(0.5, 5),
)
def test_the_axis_meets_the_ground_point(
    x: float, z: float, h: float, tilt: float, azimuth: float, tip_height: float, length: float
) -> None:
    tip, base = finger_axis((x, z), h, tilt, azimuth, tip_height, length)
    assert h - tip[1] == pytest.approx(tip_height)  # y down: above the ground is smaller y
    assert np.linalg.norm(tip - base) == pytest.approx(length)
    s = (h - tip[1]) / (tip[1] - base[1])  # from the tip on, away from the base
    np.testing.assert_allclose(tip + s * (tip - base), [x, h, z], atol=1e-9)


def test_the_azimuth_heads_from_plus_z_toward_plus_x() -> None:
    tip, base = finger_axis((0.0, 30.0), 9.625, 45.0, 90.0)
    assert tip[0] > base[0]  # pointing along +x
    assert tip[2] == pytest.approx(base[2])
    tip, base = finger_axis((0.0, 30.0), 9.625, 45.0, 180.0)
    assert tip[2] < base[2]  # back toward the camera
    tip, base = finger_axis((1.0, 30.0), 9.625, 0.0, 123.0)  # straight down: no heading
    np.testing.assert_allclose(tip[[0, 2]], [1.0, 30.0])
    np.testing.assert_allclose(base[[0, 2]], [1.0, 30.0])


def test_a_boards_corners_start_at_its_first_corner_rows_along_x_rising() -> None:
    board = BoardPlacement(inner_corners=(4, 3), square=0.5, first_corner=(-1.0, 8.0, 24.0))
    corners = board.corners_grid()
    assert corners.shape == (12, 3)
    np.testing.assert_allclose(corners[0], [-1.0, 8.0, 24.0])
    np.testing.assert_allclose(corners[3], [0.5, 8.0, 24.0])  # the first row, along +x
    np.testing.assert_allclose(corners[4], [-1.0, 7.5, 24.0])  # the next row, up (-y)
    np.testing.assert_allclose(corners[:, 2], 24.0)  # upright: one plane z
    assert BoardPlacement.from_json(board.to_json()) == board


@pytest.mark.parametrize(
    ("corners", "square", "corner", "match"),
    [
        ((1, 6), 1.0, (0, 0, 20), "inner corners"),
        ((9, 6, 2), 1.0, (0, 0, 20), "inner corners"),
        ((9.5, 6), 1.0, (0, 0, 20), "inner corners"),
        ((True, 6), 1.0, (0, 0, 20), "inner corners"),
        ((9, 6), 0.0, (0, 0, 20), "board square"),
        ((9, 6), float("nan"), (0, 0, 20), "board square"),
        ((9, 6), 1.0, (0, float("inf"), 20), "board first corner"),
    ],
)
def test_a_board_that_is_no_board_is_refused(
    corners: tuple[int, ...], square: float, corner: tuple[float, ...], match: str
) -> None:
    with pytest.raises(InputValueError, match=match):
        BoardPlacement(inner_corners=corners, square=square, first_corner=corner)  # type: ignore[arg-type]
