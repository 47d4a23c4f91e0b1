"""scene: the simulator's parameters from TOML, through the core's one TOML reader."""

from __future__ import annotations

from pathlib import Path

import pytest

from twopose.errors import SceneError
from twopose.sim.scene import Scene, load_scene


def test_defaults_are_the_thesis_rig() -> None:
    s = load_scene()
    assert s == Scene()
    cam = s.cameras[0].intrinsics
    assert (cam.width, cam.height, cam.fx, cam.cx, cam.cy) == (640, 480, 525.0, 320.0, 240.0)
    assert s.ground_height == 9.625
    assert s.finger.ground_point == (1.91, 8.375)


def test_a_file_overrides_table_by_table(tmp_path: Path) -> None:
    path = tmp_path / "scene.toml"
    path.write_text('units = "mm"\n[finger]\ntilt_deg = 40\n[poses]\nx_range = [-3, 3]\n')
    s = load_scene(path)
    assert s.units == "mm"
    assert s.finger.tilt_deg == 40.0
    assert isinstance(s.finger.tilt_deg, float)
    assert s.poses.x_range == (-3.0, 3.0)
    assert s.finger.azimuth_deg == Scene().finger.azimuth_deg  # untouched keys: defaults
    assert s.finger.length == pytest.approx(Scene().finger.length * 25.4)  # in the units


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ("[finger]\ntilt = 3\n", "unknown key.*finger.tilt"),
        ("[finger]\ntilt_deg = 'steep'\n", "finger.tilt_deg must be a finite number"),
        ("[finger]\ntilt_deg = 90\n", "finger.tilt_deg"),
        ("[poses]\nx_range = [1]\n", "poses.x_range must have 2 items"),
        ("[sensor]\nimage_format = 'gif'\n", "sensor.image_format must be one of"),
        ("[[cameras]]\ncalibration_sigma = [2, 2, -1, 0]\n", "cameras.calibration_sigma"),
        ("[[cameras]]\ncalibration_sigma = [60, 2, 1, 1]\n", "a tenth of fx"),
        ("finger = 3\n", "finger must be a table"),
        ("units = [\n", "not valid TOML"),
    ],
)
def test_bad_scene_files_name_the_key(tmp_path: Path, text: str, message: str) -> None:
    path = tmp_path / "scene.toml"
    path.write_text(text)
    with pytest.raises(SceneError, match=message):
        load_scene(path)


def test_a_missing_or_binary_file_is_a_scene_error(tmp_path: Path) -> None:
    with pytest.raises(SceneError, match="cannot read"):
        load_scene(tmp_path / "missing.toml")
    binary = tmp_path / "b.toml"
    binary.write_bytes(b"\xff\xfe\x00")
    with pytest.raises(SceneError, match="scene file"):
        load_scene(binary)


@pytest.mark.parametrize("key", ["cameras", "covariance"])
def test_a_scene_refuses_what_only_a_fit_records(tmp_path: Path, key: str) -> None:
    """The simulated rig's constants are exact: a scene gives none of what a rig file's
    fit records about them (its cameras, its covariance), in the scene's words."""
    path = tmp_path / "scene.toml"
    path.write_text(f"[systematic]\n{key} = []\n")
    with pytest.raises(SceneError, match=f"systematic.{key} is what a rig file's fit records"):
        load_scene(path)
