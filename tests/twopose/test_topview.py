"""twopose.methods.topview directly: from above, each view's ray (method 1) or ground trace (method
2)
passes through the estimate the solver found, and the line is drawn about its estimate."""

from __future__ import annotations

import numpy as np

from twopose.camera.model import Intrinsics, project_points, rotation_from_angles_deg
from twopose.display.scene import TrialScene
from twopose.methods.topview import top_view

INTRINSICS = Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0)
CENTRES = np.array([[0.0, 0.0, 0.0], [4.0, 0.0, 0.0], [2.0, -1.0, -3.0]])
R = rotation_from_angles_deg(np.array([[0.0, 0, 0], [0.0, -8.0, 0], [5.0, 3.0, 0]]))


def _px(p: np.ndarray) -> np.ndarray:
    return np.array([project_points(p[None], INTRINSICS, R[i], CENTRES[i])[0] for i in range(3)])


def _scene(
    method: str, px: np.ndarray, theta: np.ndarray, estimate: np.ndarray, **kw: object
) -> TrialScene:
    fields: dict[str, object] = {
        "trial": 4,
        "method": method,
        "status": "ok",
        "intrinsics": np.tile([525.0, 525.0, 320.0, 240.0], (3, 1)),
        "width_height": np.tile([640.0, 480.0], (3, 1)),
        "R_cam_to_grid": R,
        "t_grid": CENTRES,
        "px": px,
        "theta_deg": theta,
        "estimate": estimate,
        "direction": None,
        "truth": np.tile(estimate, (2, 1)),
        "cov": np.full((3, 3), np.nan),
    }
    fields.update(kw)
    return TrialScene(**fields)  # type: ignore[arg-type]


def _distance_to_segment_line(
    p: tuple[float, float], a: tuple[float, float], b: tuple[float, float]
) -> float:
    d, e = np.subtract(b, a), np.subtract(p, a)
    return float(abs(d[0] * e[1] - d[1] * e[0]) / np.linalg.norm(d))


def test_the_rays_meet_at_the_point_from_above() -> None:
    point = np.array([1.0, 2.0, 30.0])
    view = top_view(_scene("point", _px(point), np.full(3, np.nan), point))
    assert view.estimate == (1.0, 30.0)
    assert view.truth == (1.0, 30.0)
    assert view.cameras == ((0.0, 0.0), (4.0, 0.0), (2.0, -3.0))
    assert [kind for kind, _, _ in view.segments] == ["ray"] * 3
    for _, start, end in view.segments:
        assert _distance_to_segment_line(view.estimate, start, end) < 1e-9
        # drawn a little past the point: 1.2 times the camera's distance to it
        assert np.hypot(*np.subtract(end, start)) > np.hypot(*np.subtract(view.estimate, start))
    json = view.to_json()
    assert json["trial"] == 4
    assert json["segments"][0]["kind"] == "ray"  # type: ignore[index]


def test_each_ground_trace_passes_through_the_ground_point() -> None:
    ground_point, top = np.array([1.0, 9.625, 30.0]), np.array([1.5, 3.0, 28.0])
    a, b = _px(ground_point), _px(top)
    theta = np.degrees(np.arctan2(b[:, 1] - a[:, 1], b[:, 0] - a[:, 0]))
    view = top_view(_scene("ground", (a + b) / 2, theta, ground_point))
    assert [kind for kind, _, _ in view.segments] == ["trace"] * 3
    for _, start, end in view.segments:
        assert _distance_to_segment_line((1.0, 30.0), start, end) < 1e-9
        # centred on the foot nearest the estimate
        np.testing.assert_allclose(np.add(start, end) / 2, (1.0, 30.0), atol=1e-9)
    # Without an estimate there is no ground to cut: no traces, cameras still drawn.
    none = top_view(_scene("ground", (a + b) / 2, theta, np.full(3, np.nan)))
    assert none.segments == ()
    assert none.estimate is None
    assert len(none.cameras) == 3


def test_a_line_is_drawn_about_its_estimate_beside_the_true_line() -> None:
    a, b = np.array([0.0, 1.0, 30.0]), np.array([4.0, 1.0, 34.0])
    direction = (b - a) / np.linalg.norm(b - a)
    truth = np.stack([a, b])
    view = top_view(
        _scene("line", _px((a + b) / 2), np.zeros(3), (a + b) / 2, direction=direction, truth=truth)
    )
    kinds = [kind for kind, _, _ in view.segments]
    assert kinds == ["estimated_line", "truth_line"]
    _, start, end = view.segments[0]
    np.testing.assert_allclose(np.add(start, end) / 2, (2.0, 32.0))
    # The true line, about its midpoint along its direction, as long as the estimate's:
    # between its two typed points alone it would hide under the estimate.
    _, t0, t1 = view.segments[1]
    np.testing.assert_allclose(np.add(t0, t1) / 2, (2.0, 32.0))
    np.testing.assert_allclose(np.hypot(*np.subtract(t1, t0)), np.hypot(*np.subtract(end, start)))
    np.testing.assert_allclose(np.subtract(t1, t0)[0], np.subtract(t1, t0)[1])  # along (1, 1)
    assert view.truth is None  # a line's truth is its segment


def test_rays_without_an_estimate_reach_ten_units() -> None:
    point = np.array([1.0, 2.0, 30.0])
    view = top_view(_scene("point", _px(point), np.full(3, np.nan), np.full(3, np.nan)))
    assert view.estimate is None
    lengths = [np.hypot(*np.subtract(end, start)) for _, start, end in view.segments]
    assert len(lengths) == 3
    assert max(lengths) <= 10.0 + 1e-9


def test_a_vertical_true_line_is_drawn_as_a_point_seen_end_on() -> None:
    a, b = np.array([1.91, 9.625, 8.375]), np.array([1.91, 0.0, 8.375])
    est = np.array([1.3, 6.4, 10.6])
    direction = np.array([0.148, 0.821, -0.551])
    view = top_view(
        _scene("line", _px(est), np.zeros(3), est, direction=direction, truth=np.stack([a, b]))
    )
    assert view.truth == (1.91, 8.375)  # from above, the line is this point
