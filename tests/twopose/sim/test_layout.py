"""twopose.sim.layout directly: each method's target is placed where the scene says, on its
stand; the clutter is one draw per generator; the board joins the target when present."""

from __future__ import annotations

import numpy as np
import pytest

from twopose.methods.specs import Method
from twopose.sim.layout import board_layout, build_layout, finger_axis, srgb_to_linear
from twopose.sim.scene import load_scene


def test_the_point_target_is_the_dot_on_its_card_on_the_stand() -> None:
    scene = load_scene()
    layout = build_layout(scene, Method.POINT, np.random.default_rng(0))
    card, *stand = layout.primitives
    assert card.kind == "card"
    np.testing.assert_array_equal(card.dot_center, scene.point.position)
    assert card.dot_radius == scene.point.dot_radius
    np.testing.assert_allclose(card.dot_color, srgb_to_linear(scene.point.dot_color))
    assert [p.kind for p in stand] == ["capsule", "capsule", "box"]
    # The base stands on the ground (y = h, y down).
    assert stand[2].b[1] == pytest.approx(scene.ground_height)


@pytest.mark.parametrize("method", ["line", "ground"])
def test_the_finger_is_a_capsule_along_its_axis_that_meets_the_ground_point(method: str) -> None:
    scene = load_scene()
    finger = build_layout(scene, Method(method), np.random.default_rng(0)).primitives[0]
    tip, base = finger_axis(scene)
    assert finger.kind == "capsule"
    np.testing.assert_array_equal(finger.a, base)
    np.testing.assert_array_equal(finger.b, tip)
    assert finger.radius == scene.finger.radius
    # Extended past the tip, the axis reaches y = h at the scene's ground point.
    s = (scene.ground_height - base[1]) / (tip[1] - base[1])
    on_ground = base + s * (tip - base)
    np.testing.assert_allclose(on_ground[[0, 2]], scene.finger.ground_point)  # (x, z)


def test_the_clutter_is_one_draw_per_generator() -> None:
    scene = load_scene()
    first = build_layout(scene, Method.GROUND, np.random.default_rng(5)).decals
    again = build_layout(scene, Method.GROUND, np.random.default_rng(5)).decals
    other = build_layout(scene, Method.GROUND, np.random.default_rng(6)).decals
    assert len(first) > 0
    assert {d.surface for d in first} <= {"table", "back_wall"}
    assert [d.center.tolist() for d in first] == [d.center.tolist() for d in again]
    assert [d.center.tolist() for d in first] != [d.center.tolist() for d in other]
    none = load_scene(clutter={"count": 0})
    assert build_layout(none, Method.GROUND, np.random.default_rng(5)).decals == ()


def test_a_present_board_joins_the_target_and_stands_alone_in_a_board_layout() -> None:
    scene = load_scene(board={"present": True})
    kinds = [p.kind for p in build_layout(scene, Method.POINT, np.random.default_rng(0)).primitives]
    assert kinds[0] == "card"
    assert kinds[-1] == "checkerboard"
    alone = board_layout(scene)
    assert [p.kind for p in alone.primitives] == ["checkerboard"]
    assert alone.decals == ()
