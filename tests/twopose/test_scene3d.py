"""twopose.display.scene directly: a trial's Foxglove scene holds the cameras, the measured rays
(points) or planes (lines, method 2), the estimate with its 95% ellipsoid, the truth and
the error; the rays pass through the target; a failed trial has no estimate entities."""

from __future__ import annotations

import numpy as np

from twopose.display.scene import TrialScene, static_scene, trial_scene
from twopose.format.entries import PlaneEntry

TARGET = np.array([0.5, 1.5, 11.0])
K = np.array([525.0, 525.0, 320.0, 240.0])


def _px(t: np.ndarray) -> np.ndarray:
    p = TARGET - t  # camera axes = grid axes (no rotation)
    return np.array([K[0] * p[0] / p[2] + K[2], K[1] * p[1] / p[2] + K[3]])


def _scene(method: str = "point", estimate: np.ndarray = TARGET, status: str = "ok") -> TrialScene:
    centres = np.array([[0.0, 0.0, 0.0], [2.0, 0.0, 0.0]])
    return TrialScene(
        trial=3,
        method=method,
        status=status,
        intrinsics=np.tile(K, (2, 1)),
        width_height=np.tile([640.0, 480.0], (2, 1)),
        R_cam_to_grid=np.tile(np.eye(3), (2, 1, 1)),
        t_grid=centres,
        px=np.stack([_px(c) for c in centres]),
        theta_deg=np.full(2, np.nan) if method == "point" else np.array([80.0, 85.0]),
        estimate=estimate,
        direction=None if method != "line" else np.array([0.0, 1.0, 0.0]),
        truth=np.stack([TARGET, TARGET]),
        cov=np.diag([0.01, 0.02, 0.04]),
    )


def _entities(method: str = "point", **kw: object) -> dict[str, object]:
    update = trial_scene(_scene(method, **kw), 1000)  # type: ignore[arg-type]
    return {e.id: e for e in update.entities}


def test_a_point_trial_has_every_entity_and_its_rays_meet_at_the_target() -> None:
    e = _entities("point")
    assert set(e) == {"cameras", "measurements", "estimate", "truth", "error", "label"}
    rays = e["measurements"].lines[0].points  # type: ignore[attr-defined]
    assert len(rays) == 4  # two segments: each camera's centre and far end
    for start, end in zip(rays[::2], rays[1::2], strict=True):
        a = np.array([start.x, start.y, start.z])
        b = np.array([end.x, end.y, end.z])
        d = (b - a) / np.linalg.norm(b - a)
        off = (TARGET - a) - ((TARGET - a) @ d) * d  # the target's distance from the ray
        assert np.linalg.norm(off) < 1e-9
    label = e["label"].texts[0]  # type: ignore[attr-defined]
    assert label.text == "trial 3: ok"
    assert e["cameras"].frame_id == "grid"  # type: ignore[attr-defined]


def test_line_and_ground_trials_draw_planes_and_a_line_its_direction() -> None:
    ground = _entities("ground")
    assert len(ground["measurements"].triangles[0].points) == 6  # type: ignore[attr-defined]
    line = _entities("line")
    strips = line["estimate"].lines  # type: ignore[attr-defined]
    assert len(strips) == 1  # the estimated line through the estimate
    p0, p1 = strips[0].points
    d = np.array([p1.x - p0.x, p1.y - p0.y, p1.z - p0.z])
    np.testing.assert_allclose(d / np.linalg.norm(d), [0.0, 1.0, 0.0], atol=1e-12)


def test_a_failed_trial_draws_no_estimate() -> None:
    e = _entities("point", estimate=np.full(3, np.nan), status="degenerate")
    assert "estimate" not in e
    assert "error" not in e
    assert e["label"].texts[0].text == "trial 3: degenerate"  # type: ignore[attr-defined]


def test_the_static_scene_draws_the_ground_plane_when_there_is_one() -> None:
    with_ground = static_scene(PlaneEntry(offset=9.625))
    without = static_scene(None)
    assert len(with_ground.entities) > len(without.entities)
