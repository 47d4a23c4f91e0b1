"""twopose.sim.render directly: the dot is rendered where the camera model projects it, with
the card's brightness around it; the exposure is one draw per generator, and with no jitter
or noise it is the radiance through the sensor's gamma, in OpenCV's BGR order."""

from __future__ import annotations

import numpy as np

from twopose.camera.model import project_points
from twopose.methods.specs import Method
from twopose.sim.layout import GAMMA, build_layout
from twopose.sim.render import _box_filtered_checker, expose, render_radiance
from twopose.sim.scene import load_scene

R = np.eye(3)
T = np.zeros(3)


def test_the_dot_is_dark_where_it_projects_on_a_light_card() -> None:
    scene = load_scene(clutter={"count": 0})
    intr = scene.cameras[0].intrinsics
    layout = build_layout(scene, Method.POINT, np.random.default_rng(0))
    radiance = render_radiance(scene, layout, intr, R, T)
    assert radiance.shape == (intr.height, intr.width, 3)
    assert radiance.dtype == np.float32
    col, row = project_points(np.array([scene.point.position]), intr, R, T)[0]
    dot = radiance[round(row), round(col)].mean()
    # 1.5 dot radii to the left: still on the card (offset +0.8 in, 5 in wide), off the dot
    beside_px = 1.5 * scene.point.dot_radius * intr.fx / scene.point.position[2]
    card = radiance[round(row), round(col - beside_px)].mean()
    assert card > 5 * dot
    # Without the target the same pixel is the background, not a dot.
    empty = render_radiance(
        scene, build_layout(scene, Method.GROUND, np.random.default_rng(0)), intr, R, T
    )
    assert empty[round(row), round(col)].mean() > 2 * dot


def test_an_exposure_is_one_draw_per_generator() -> None:
    scene = load_scene()
    radiance = np.full((48, 64, 3), 0.25, np.float32)
    first = expose(radiance, scene, np.random.default_rng(1))
    assert first.dtype == np.uint8
    assert first.shape == (48, 64, 3)
    np.testing.assert_array_equal(first, expose(radiance, scene, np.random.default_rng(1)))
    assert not np.array_equal(first, expose(radiance, scene, np.random.default_rng(2)))


def test_a_still_noiseless_exposure_is_the_gamma_of_the_radiance_in_bgr() -> None:
    scene = load_scene(
        lighting={
            "gain_jitter": 0.0,
            "white_balance_jitter": 0.0,
            "gradient_jitter": 0.0,
            "vignetting": 0.0,
        },
        sensor={"read_noise_dn": 0.0, "shot_noise_dn": 0.0},
    )
    radiance = np.zeros((4, 6, 3), np.float32)
    radiance[..., 0] = 0.5  # red
    radiance[..., 2] = 2.0  # blue, over-exposed: clipped
    frame = expose(radiance, scene, np.random.default_rng(0))
    red = round(255 * 0.5 ** (1 / GAMMA))
    assert (frame[..., 2] == red).all()  # BGR: red last
    assert (frame[..., 1] == 0).all()
    assert (frame[..., 0] == 255).all()


def test_the_board_is_averaged_over_each_sample_exactly() -> None:
    """The box-filtered checker equals a brute-force average over the footprint, is 0 off
    the pattern and the point-sampled parity when the footprint shrinks."""
    rng = np.random.default_rng(4)
    x, y = rng.uniform(-1.5, 11.5, 200), rng.uniform(-1.5, 8.5, 200)
    width = rng.uniform(0.05, 2.5, (200, 2))
    squares = (10, 7)
    exact = _box_filtered_checker(x, y, width, squares)
    grid = (np.arange(400) + 0.5) / 400 - 0.5  # 400 x 400 samples across the footprint
    sx = x[:, None] + grid[None] * width[:, :1]
    sy = y[:, None] + grid[None] * width[:, 1:]
    inside_x = (sx >= 0) & (sx < squares[0])
    inside_y = (sy >= 0) & (sy < squares[1])
    even_x, even_y = np.floor(sx) % 2 == 0, np.floor(sy) % 2 == 0
    inside = inside_x[:, :, None] & inside_y[:, None, :]
    dark = inside & (even_x[:, :, None] == even_y[:, None, :])
    np.testing.assert_allclose(exact, dark.mean(axis=(1, 2)), atol=0.01)
    assert exact.min() >= 0
    assert exact.max() <= 1
    outside = np.array([-3.0, 20.0])
    off = _box_filtered_checker(outside, np.array([2.0, 2.0]), np.ones((2, 2)), squares)
    np.testing.assert_array_equal(off, 0.0)
    tiny = _box_filtered_checker(x, y, np.full((200, 2), 1e-6), squares)
    parity = (np.floor(x) + np.floor(y)) % 2 == 0
    on = (x >= 0) & (x < squares[0]) & (y >= 0) & (y < squares[1])
    np.testing.assert_allclose(tiny, (parity & on).astype(float), atol=1e-3)
