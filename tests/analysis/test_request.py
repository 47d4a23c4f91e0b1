"""request: the `solve` hand-check request, called directly (the CLI test runs it as JSON)."""

from __future__ import annotations

import numpy as np
import pytest

from analysis.tools.solve_request import solve_request
from twopose.camera.model import Intrinsics, project_points, rotation_from_angles_deg
from twopose.errors import InputValueError
from twopose.methods.specs import Method

INTR = Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0)
POSES = [((0.0, 0.0, 0.0), (0.0, 0.0, 0.0)), ((1.1, 0.0, 0.0), (0.0, 5.0, 0.0))]


def _view(t: tuple[float, ...], r: tuple[float, ...], **measurement: object) -> dict[str, object]:
    return {
        "K": [525.0, 525.0, 320.0, 240.0],
        "pose": {"t": list(t), "r_deg": list(r)},
        **measurement,
    }


def _px(p: np.ndarray, t: tuple[float, ...], r: tuple[float, ...]) -> list[float]:
    return [float(v) for v in project_points(p, INTR, rotation_from_angles_deg(r), t)[0]]


@pytest.mark.parametrize("estimator", ["thesis", "optimal"])
def test_point_request_recovers_the_point(estimator: str) -> None:
    target = np.array([0.5, 1.5, 11.0])
    views = [_view(t, r, px=_px(target, t, r)) for t, r in POSES]
    answer = solve_request(Method.POINT, {"views": views, "estimator": estimator})
    assert answer["status"] == "ok"
    np.testing.assert_allclose(answer["point"], target, atol=1e-6)
    assert answer["n_views"] == 2
    assert answer["reprojection_rms_px"] == pytest.approx(0.0, abs=1e-6)


def test_ground_and_line_requests_from_a_projected_segment() -> None:
    a, b = np.array([1.91, 9.625, 8.375]), np.array([1.0, 5.0, 10.0])  # on the ground at a
    views = []
    for t, r in POSES:
        seg = _px(a, t, r) + _px(b, t, r)
        views.append(_view(t, r, line={"segment_px": seg}))
    ground = solve_request(Method.GROUND, {"views": views, "ground_y": 9.625})
    np.testing.assert_allclose(ground["point"], a, atol=1e-6)
    line = solve_request(Method.LINE, {"views": views})
    d = np.array(line["line"]["direction"])
    np.testing.assert_allclose(abs(d @ (b - a)) / np.linalg.norm(b - a), 1.0, atol=1e-9)


def test_identical_views_are_degenerate_not_ok() -> None:
    view = _view(*POSES[0], px=[320.0, 240.0])
    answer = solve_request(Method.POINT, {"views": [view, view]})
    assert answer["status"] == "degenerate"
    assert answer["point"] is None


@pytest.mark.parametrize(
    ("request_", "message"),
    [
        ({"views": []}, "needs 2 or more"),
        ({}, "'views'"),
        ({"views": [_view(*POSES[0], px=[1, 2])] * 2, "estimator": "magic"}, "estimator"),
        ({"views": [{"K": [0, 1, 2, 3], "pose": {"t": [0, 0, 0]}, "px": [1, 2]}] * 2}, "fx and fy"),
        ({"views": [_view(*POSES[0], px=[1, "a"])] * 2}, "px must be a number"),
        ({"views": [_view(*POSES[0], px=[1, float("nan")])] * 2}, "finite numbers"),
    ],
)
def test_malformed_requests_say_what_is_wrong(request_: dict[str, object], message: str) -> None:
    with pytest.raises(InputValueError, match=message):
        solve_request(Method.POINT, request_)


def test_a_board_reconstructs_nothing_and_says_where_to_go() -> None:
    from twopose.errors import InputValueError

    with pytest.raises(InputValueError, match="twopose-analyze rig"):
        solve_request(Method.BOARD, {"views": []})
