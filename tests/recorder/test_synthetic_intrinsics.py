"""Issue 44 (4): the synthetic camera sees the scene through the session's intrinsics.

A plan at ``focal = 700`` recorded with ``--source synthetic`` was rendered with the
scene's own camera (f = 525 px) and analysed at 700 px: every trial came out 2.7-3.1 in
off, with no warning. Now the scene is rendered through the session's camera (focal,
principal point, image size), its own camera kept when they are the same, and a camera it
cannot render is refused before anything is recorded.
"""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

import analysis
from recorder.cli.app import app
from recorder.sources.registry import SyntheticSource, open_source
from twopose.camera.model import Camera, Intrinsics
from twopose.errors import InputValueError
from twopose.methods.specs import Method
from twopose.sim.scene import load_scene

runner = CliRunner()

#: The bundled example's last trial (docs/examples/ground_plan.toml), two frames a pose;
#: the default scene at one ray per pixel, to keep the test quick.
SCENE = "[sensor]\nsupersample = 1\n"
PLAN = """method = "ground"
units = "in"
frames = 2
ground_height = 9.625
[camera]
focal = {focal}
principal = [320.0, 240.0]
[[trials]]
ground_truth = [[1.91, 9.625, 8.375]]
poses = [{{ t = [0.0, 0.0, -1.0] }}, {{ t = [2.0, 0.0, -1.0] }}]
"""


def _intrinsics(fx: float, width: int = 640, height: int = 480) -> Intrinsics:
    return Intrinsics(width=width, height=height, fx=fx, fy=fx, cx=width / 2, cy=height / 2)


def test_the_same_plan_at_focal_525_and_700_gives_the_same_small_errors(tmp_path: Path) -> None:
    """``new --plan P --source synthetic:SCENE`` at f = 525 and 700 px, analysed
    (``analysis.run``): both trials good, their errors alike (700 was about 3 in off)."""
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE)
    errors = {}
    for focal in (525.0, 700.0):
        plan, out = tmp_path / f"f{focal:g}.toml", tmp_path / f"f{focal:g}.mcap"
        plan.write_text(PLAN.format(focal=focal))
        source = f"synthetic:{scene}"
        result = runner.invoke(app, ["new", str(out), "--plan", str(plan), "--source", source])
        assert result.exit_code == 0, result.output
        trials = analysis.run([out], jobs=1).trials
        assert list(trials["status"]) == ["ok"]
        errors[focal] = float(trials["err"].iloc[0])
    assert max(errors.values()) < 0.25, errors
    assert abs(errors[700.0] - errors[525.0]) < 0.15, errors


def test_the_scene_is_seen_through_the_sessions_camera() -> None:
    """The scene's own camera when the session's is the same (the same scene: the same
    bytes); otherwise its focal, principal point and image size are the session's."""
    own = load_scene()
    same = open_source(
        "synthetic", method=Method.GROUND,
        cameras=[Camera(camera_id="cam0", intrinsics=own.cameras[0].intrinsics)],
    )  # fmt: skip
    assert isinstance(same, SyntheticSource)
    assert same.scene == own
    k = Intrinsics(width=800, height=600, fx=1234.56789, fy=1230.0, cx=401.5, cy=298.25)
    source = SyntheticSource(cameras=[Camera(camera_id="cam0", intrinsics=k)])
    assert source.scene.cameras[0].intrinsics == k
    assert source.scene.cameras[0].id == own.cameras[0].id
    assert SyntheticSource().scene == own  # no session camera: the scene's


def test_a_camera_the_scene_cannot_render_is_refused_with_a_reason(tmp_path: Path) -> None:
    """Two cameras of different intrinsics (the synthetic camera renders one), or
    intrinsics the scene's check refuses: an InputValueError saying why and what to do."""
    two = [
        Camera(camera_id="cam0", intrinsics=_intrinsics(525.0)),
        Camera(camera_id="cam1", intrinsics=_intrinsics(700.0)),
    ]
    with pytest.raises(InputValueError, match="cam0 and cam1 have different intrinsics"):
        open_source("synthetic", cameras=two)
    scene = tmp_path / "scene.toml"
    scene.write_text("[[cameras]]\ncalibration_sigma = [30.0, 30.0, 1.0, 1.0]\n")
    small = [Camera(camera_id="cam0", intrinsics=_intrinsics(200.0))]
    with pytest.raises(InputValueError, match="cannot render the session's camera cam0"):
        open_source(f"synthetic:{scene}", cameras=small)


def test_a_plan_the_synthetic_camera_cannot_render_records_nothing(tmp_path: Path) -> None:
    """From the command line: refused before the file is created."""
    plan, out = tmp_path / "two.toml", tmp_path / "two.mcap"
    two = "".join(
        f'[[cameras]]\nid = "{name}"\nfocal = {f}\n' for name, f in (("a", 525.0), ("b", 700.0))
    )
    body = (
        PLAN.format(focal=525.0)
        .replace("[camera]\nfocal = 525.0\n", "")
        .replace("principal = [320.0, 240.0]\n", "")
    )
    plan.write_text(body.replace("[[trials]]", two + "[[trials]]", 1))
    result = runner.invoke(app, ["new", str(out), "--plan", str(plan), "--source", "synthetic"])
    assert result.exit_code != 0
    assert "a and b have different intrinsics" in result.output
    assert not out.exists()
