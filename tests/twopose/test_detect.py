"""Detectors on drawn and rendered frames with known truth; per-pose combination."""

from __future__ import annotations

import time
from typing import Any

import cv2
import numpy as np
import pytest

from twopose.camera.model import project_points
from twopose.detect.detection import (
    DotParams,
    GloveParams,
    detect,
    detect_dot,
    detect_glove,
    wrap_theta_deg,
)
from twopose.methods.specs import Method
from twopose.sim.layout import build_layout, finger_axis
from twopose.sim.render import expose, render_radiance
from twopose.sim.scene import load_scene
from twopose.values.choices import Target

GLOVE_BGR = (192, 108, 38)


def _drawn_finger(
    theta_deg: float,
    center: tuple[float, float] = (320.0, 240.0),
    length: float = 120.0,
    width: float = 30.0,
) -> np.ndarray:
    """A glove-blue stadium on grey, at sub-pixel precision (cv2 shift=4)."""
    img = np.full((480, 640, 3), 128, np.uint8)
    t = np.radians(theta_deg)
    half = np.array([np.cos(t), np.sin(t)]) * (length - width) / 2
    a, b = np.array(center) - half, np.array(center) + half
    s = 16
    cv2.line(
        img,
        tuple(np.round(a * s).astype(int)),
        tuple(np.round(b * s).astype(int)),
        GLOVE_BGR,
        int(width),
        lineType=cv2.LINE_AA,
        shift=4,
    )
    return img


@pytest.mark.parametrize("theta", [-89.0, -60.0, -30.0, 0.0, 15.0, 45.0, 75.0, 89.0, 90.0])
def test_orientation_convention_on_a_drawn_line(theta: float) -> None:
    """theta is measured from +col toward +row (row down), in (-90, 90]."""
    d = detect_glove(_drawn_finger(theta), GloveParams(pi_min=2.5, pi_max=3.2))
    assert d.found, d.reason
    diff = float(wrap_theta_deg(d.theta_deg - theta))
    assert abs(diff) < 0.5
    assert -90 < d.theta_deg <= 90
    np.testing.assert_allclose(d.centroid_px, (320.0, 240.0), atol=0.3)


def test_a_line_going_down_to_the_right_has_positive_theta() -> None:
    img = np.full((200, 200, 3), 128, np.uint8)
    cv2.line(img, (40, 40), (160, 160), GLOVE_BGR, 30)  # +col and +row together
    d = detect_glove(img, GloveParams(pi_min=2.0, pi_max=3.5))
    assert d.found
    assert d.theta_deg == pytest.approx(45.0, abs=0.5)


def _render(
    scene_overrides: dict[str, Any],
    t_grid: tuple[float, float, float],
    method: str = "ground",
    seed: int = 0,
) -> tuple[np.ndarray, np.ndarray]:
    scene = load_scene(**scene_overrides)
    layout = build_layout(scene, Method(method), np.random.default_rng(seed))
    intr = scene.cameras[0].intrinsics
    rad = render_radiance(scene, layout, intr, np.eye(3), np.array(t_grid))
    img = expose(rad, scene, np.random.default_rng(seed + 1))
    ok, buf = cv2.imencode(".jpg", img, [cv2.IMWRITE_JPEG_QUALITY, 85])
    assert ok
    decoded = cv2.imdecode(buf, cv2.IMREAD_COLOR)
    assert decoded is not None
    if method == "point":
        truth = project_points(np.array([scene.point.position]), intr, np.eye(3), t_grid)
    else:
        truth = project_points(np.stack(finger_axis(scene)), intr, np.eye(3), t_grid)
    return decoded, truth


@pytest.mark.parametrize("azimuth", [150.0, 165.0, 180.0, 195.0, 210.0])
@pytest.mark.parametrize("t_grid", [(-2.0, 0.0, -2.0), (0.0, 0.0, 0.0), (2.0, 0.0, 1.0)])
def test_glove_found_on_the_projected_axis_with_clutter(
    azimuth: float, t_grid: tuple[float, float, float]
) -> None:
    img, (tip, base) = _render(
        {"finger": {"azimuth_deg": azimuth}, "clutter": {"count": 8}}, t_grid
    )
    d = detect_glove(img)
    assert d.found, d.reason
    axis = (tip - base) / np.linalg.norm(tip - base)
    normal = np.array([-axis[1], axis[0]])
    assert abs((np.array(d.centroid_px) - base) @ normal) < 0.5
    truth_deg = np.degrees(np.arctan2(axis[1], axis[0]))
    assert abs(float(wrap_theta_deg(d.theta_deg - truth_deg))) < 1.0
    assert 2.90 <= d.pi_estimate <= 3.08
    assert d.n_blobs > 1  # the clutter was there and was rejected


def test_near_vertical_finger_wraps_correctly() -> None:
    # azimuth 180 and the camera right in front of the finger: the image line is vertical.
    scene = {
        "finger": {"azimuth_deg": 180.0, "ground_point": [0.0, 8.375]},
        "clutter": {"count": 0},
    }
    img, _ = _render(scene, (0.0, 0.0, 0.0))
    d = detect_glove(img)
    assert d.found
    assert abs(abs(d.theta_deg) - 90.0) < 1.0


@pytest.mark.parametrize(
    ("params", "reason"),
    [
        (GloveParams(min_area_px=1e6), "none larger than"),
        (GloveParams(ecc_min=0.999), "eccentricity"),
        (GloveParams(pi_min=3.2, pi_max=3.3), "pi estimate"),
        (GloveParams(b_min=0.99), "no glove-coloured pixels"),
    ],
)
def test_each_filter_says_why_it_rejected(params: GloveParams, reason: str) -> None:
    img, _ = _render({"clutter": {"count": 0}}, (0.0, 0.0, 0.0))
    d = detect_glove(img, params)
    assert not d.found
    assert reason in d.reason


def test_two_fingers_are_ambiguous() -> None:
    img = _drawn_finger(30.0, (200.0, 240.0))
    img2 = _drawn_finger(-30.0, (450.0, 240.0))
    both = np.minimum(img, img2)
    both[img2 != 128] = img2[img2 != 128]
    d = detect_glove(both, GloveParams(pi_min=2.5, pi_max=3.2))
    assert not d.found
    assert "ambiguous" in d.reason
    assert d.n_candidates == 2


@pytest.mark.parametrize(
    "t_grid", [(-2.0, 0.0, -2.0), (0.0, 0.0, 0.0), (2.0, 0.0, 1.0), (1.0, 0.0, -1.0)]
)
def test_dot_subpixel_centroid(t_grid: tuple[float, float, float]) -> None:
    img, truth = _render({"clutter": {"count": 8}}, t_grid, method="point")
    d = detect_dot(img)
    assert d.found, d.reason
    assert np.linalg.norm(np.array(d.centroid_px) - truth[0]) < 0.15


def test_a_dark_coloured_mark_is_not_the_dot() -> None:
    """A navy mark on bright paper out-contrasts the black dot on its greyer card (as in a
    rendered view where every frame took the mark): the dot is grey, the mark is not."""
    img = np.full((480, 640, 3), 200, np.uint8)
    img[380:, :] = 250  # the bright paper
    cv2.circle(img, (200, 300), 8, (22, 20, 21), -1, lineType=cv2.LINE_AA)
    cv2.ellipse(img, (420, 450), (10, 7), 0, 0, 360, (104, 30, 20), -1, lineType=cv2.LINE_AA)
    d = detect_dot(img)
    assert d.found, d.reason
    assert np.linalg.norm(np.array(d.centroid_px) - (200, 300)) < 0.5
    assert any("coloured" in b.reason for b in d.rejected_blobs)
    only_the_mark = img.copy()
    cv2.circle(only_the_mark, (200, 300), 12, (200, 200, 200), -1)
    missed = detect_dot(only_the_mark)
    assert not missed.found
    assert "grey" in missed.reason


def test_dot_not_found_on_a_blank_image() -> None:
    d = detect_dot(np.full((480, 640, 3), 200, np.uint8))
    assert not d.found
    assert d.reason
    assert not detect_dot(np.full((480, 640, 3), 200, np.uint8), DotParams(min_contrast=10)).found


@pytest.mark.parametrize("target", ["glove", "dot"])
def test_an_empty_scene_is_a_not_found_detection_with_a_reason(target: Target) -> None:
    """Nothing to find: not found, every measured value NaN (never a stale or zero centroid
    that could reach a solver), and a reason the operator can read."""
    blank = np.full((96, 128, 3), 200, np.uint8)
    d = detect(blank, target)
    assert not d.found
    assert d.reason
    assert np.isnan(d.centroid_px).all()
    assert np.isnan([d.theta_deg, d.area_px, d.eccentricity]).all()
    assert d.n_candidates == 0


@pytest.mark.parametrize("seed", range(6))
def test_fast_components_agree_with_opencv_stats(seed: int) -> None:
    """Random masks with holes and blobs inside holes: same components, areas and centroids."""
    from twopose.detect.detectors import _components

    rng = np.random.default_rng(seed)
    noise = cv2.GaussianBlur(rng.random((240, 320)).astype(np.float32), (0, 0), 3.0)
    mask = ((noise > np.quantile(noise, 0.6)) & (noise < np.quantile(noise, 0.93))).astype(np.uint8)
    n, _, stats, cents = cv2.connectedComponentsWithStats(mask, connectivity=8)
    n_blobs, shapes = _components(mask, 30.0)
    assert n_blobs == n - 1
    want = sorted(
        (int(stats[i, 4]), *np.round(cents[i], 6)) for i in range(1, n) if stats[i, 4] >= 30
    )
    got = sorted((int(s.area), round(s.centroid[0], 6), round(s.centroid[1], 6)) for s in shapes)
    assert got == want
    assert len(want) > 3


def test_the_live_board_search_finds_what_the_full_one_finds_and_turns_down_blank_frames() -> None:
    """The recorder's live check (fast pre-check, then the full search) finds a board
    exactly as the full search does, and a frame without one is not found (the full
    search ran, and said so)."""
    from twopose.detect.checkerboard import find_board, find_board_live

    squares = (np.indices((7, 10)).sum(axis=0) % 2).astype(np.uint8) * 255
    board = np.kron(squares, np.ones((30, 30), np.uint8))
    image = np.full((480, 640), 255, np.uint8)
    image[135:345, 170:470] = board
    bgr = np.asarray(cv2.cvtColor(image, cv2.COLOR_GRAY2BGR), dtype=np.uint8)
    full, live = find_board(bgr, (9, 6), window_px=None), find_board_live(bgr, (9, 6))
    assert full is not None
    assert live.corners is not None
    assert live.fast
    np.testing.assert_array_equal(full, live.corners)
    blank = np.random.default_rng(0).integers(80, 100, (480, 640, 3), dtype=np.uint8)
    none = find_board_live(blank, (9, 6), budget_s=60.0)  # a loaded machine is slow
    assert none.corners is None
    assert not none.timed_out
    assert none.full_s > 0


def test_the_live_board_search_is_bounded_in_time() -> None:
    """A full search that outlasts its budget is given up (the board counts as not found,
    said as out of time); the one still running delays the next only within its budget."""
    from twopose.detect.checkerboard import find_board_live

    blank = np.random.default_rng(1).integers(80, 100, (240, 320, 3), dtype=np.uint8)
    started = time.perf_counter()
    late = find_board_live(blank, (9, 6), budget_s=0.0)
    assert time.perf_counter() - started < 0.2
    assert late.corners is None
    assert late.timed_out
    again = find_board_live(blank, (9, 6), budget_s=5.0)
    assert not again.timed_out
    assert again.corners is None
    assert again.full_s < 5.0
