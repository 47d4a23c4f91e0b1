"""The one synthetic camera: the recorder's ``--source synthetic`` renders where the scene's
rig really puts the camera, as ``simulate`` does, so the dot is seen where the true pose
and the true intrinsics project it, not where the typed pose would."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from recorder.simulate.one_camera import target_points
from recorder.sources.registry import open_source
from twopose.camera.model import project_points, rotation_from_angles_deg
from twopose.detect.detection import detect_dot
from twopose.methods.specs import Method
from twopose.rig.constants import RigConstants
from twopose.sim.camera import camera_pose, true_intrinsics
from twopose.sim.scene import load_scene

RIG = """
[clutter]
count = 0

[systematic]
mount_rotation_deg = [0.0, 2.0, 0.0]
camera_offset = [0.3, 0.0, 0.0]
focal_scale = 1.05
principal_offset_px = [6.0, -4.0]
"""
TYPED = ((0.5, 0.0, 0.0), (0.0, 0.0, 0.0))


def _dot_seen(scene_path: Path) -> np.ndarray:
    source = open_source(f"synthetic:{scene_path}", method=Method.POINT, realtime=False)
    source.open()
    try:
        source.set_pose(*TYPED)  # what the operator typed
        found = [detect_dot(source.read()) for _ in range(3)]
    finally:
        source.close()
    assert all(d.found for d in found)
    return np.mean([d.centroid_px for d in found], axis=0)


def _projected(rig: RigConstants, scene_path: Path) -> np.ndarray:
    scene = load_scene(scene_path)
    t, r = camera_pose(rig, np.array(TYPED[0]), np.array(TYPED[1]))
    intrinsics = true_intrinsics(rig, scene.cameras[0].intrinsics)
    _, dot = target_points(scene, Method.POINT)
    projected: np.ndarray = project_points(dot, intrinsics, rotation_from_angles_deg(r), t)
    return projected[0]


def test_the_recorders_synthetic_camera_applies_the_rig(tmp_path: Path) -> None:
    with_rig, without = tmp_path / "rig.toml", tmp_path / "plain.toml"
    with_rig.write_text(RIG)
    without.write_text("[clutter]\ncount = 0\n")
    rig = load_scene(with_rig).systematic
    assert not rig.is_identity
    seen, seen_plain = _dot_seen(with_rig), _dot_seen(without)
    where_rig, where_typed = _projected(rig, with_rig), _projected(RigConstants(), without)
    # The rig moves the dot in the image by tens of pixels ...
    assert np.linalg.norm(where_rig - where_typed) > 20
    # ... and the recorder's camera sees it where the rig puts it (sub-pixel-ish, as the
    # detector finds a rendered dot), while without the rig it sees it at the typed pose.
    assert seen == pytest.approx(where_rig, abs=1.0)
    assert seen_plain == pytest.approx(where_typed, abs=1.0)
