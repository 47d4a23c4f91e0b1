"""Issue 44 (4): the synthetic camera renders its scene in the session's units.

A plan in centimetres recorded with ``--source synthetic`` rendered the default scene in
inches: its typed poses and ground truth were read as inches, and every trial came out
17.1 cm off ("check the truth and poses"). Now the same plan written in inches,
centimetres and millimetres records the same trials up to scale, and a session set up at
the terminal or in the page with ``--units cm`` renders the scene in centimetres.
"""

from __future__ import annotations

import time
from pathlib import Path

import httpx
import numpy as np
import pytest
from typer.testing import CliRunner

import analysis
from recorder.cli.app import app
from recorder.sources.registry import SyntheticSource, open_source
from tests.helpers import start_console
from twopose.methods.specs import Method
from twopose.values.units import Units, unit_factor

runner = CliRunner()

#: The bundled example's geometry in inches (docs/examples/ground_plan.toml): the finger
#: points at (1.91, 9.625, 8.375); a trial of two poses.
GROUND = 9.625
TRUTH = (1.91, 9.625, 8.375)
POSES = (((0.0, 0.0, -1.0), (2.0, 0.0, -1.0)),)
#: The default scene (in inches), one ray per pixel to keep the test quick: a scene file's
#: units are converted to the session's as the default scene's are.
SCENE = "[sensor]\nsupersample = 1\n"


def _plan(units: str) -> str:
    """The one plan written in ``units``: every length the inch value converted."""
    k = unit_factor("in", units)

    def vec(v: tuple[float, ...]) -> str:
        return "[" + ", ".join(f"{x * k!r}" for x in v) + "]"

    trials = "".join(
        f"\n[[trials]]\nground_truth = [{vec(TRUTH)}]\n"
        f"poses = [{{ t = {vec(a)} }}, {{ t = {vec(b)} }}]\n"
        for a, b in POSES
    )
    return (
        f'method = "ground"\nunits = "{units}"\nframes = 2\nground_height = {GROUND * k!r}\n'
        f"[camera]\nfocal = 525.0\nprincipal = [320.0, 240.0]\n{trials}"
    )


def test_the_same_plan_in_three_units_gives_the_same_trials_up_to_scale(tmp_path: Path) -> None:
    """Recorded from the command line (``new --plan P --source synthetic:SCENE``, the scene
    in inches) and analysed (``analysis.run``): each unit's errors are the inch plan's times
    the factor."""
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE)
    errors = {}
    for units in ("in", "cm", "mm"):
        plan, out = tmp_path / f"{units}.toml", tmp_path / f"{units}.mcap"
        plan.write_text(_plan(units))
        source = f"synthetic:{scene}"
        result = runner.invoke(app, ["new", str(out), "--plan", str(plan), "--source", source])
        assert result.exit_code == 0, result.output
        assert "beyond its 95% region" not in result.output
        trials = analysis.run([out], jobs=1).trials
        assert list(trials["status"]) == ["ok"] * len(POSES)
        assert set(trials["units"]) == {units}
        errors[units] = trials[["err_x", "err_y", "err_z", "err"]].to_numpy(dtype=float)
    assert np.abs(errors["in"][:, -1]).max() < 0.5  # the inch plan's trials are good
    for units in ("cm", "mm"):
        np.testing.assert_allclose(
            errors[units] / unit_factor("in", units), errors["in"], rtol=1e-3, atol=1e-4
        )


def test_the_synthetic_scene_follows_the_sessions_units(tmp_path: Path) -> None:
    """``open_source("synthetic", units=...)`` (the terminal's, the page's and a plan's
    setup): the scene converted, a scene file's own units converted likewise; without
    units, the scene as written."""
    cm = open_source("synthetic", method=Method.GROUND, units=Units.CM)
    assert isinstance(cm, SyntheticSource)
    assert cm.scene.units == "cm"
    assert cm.scene.ground_height == pytest.approx(GROUND * 2.54)
    scene = tmp_path / "scene.toml"
    scene.write_text('units = "mm"\nground_height = 250.0\n')
    source = open_source(f"synthetic:{scene}", method=Method.GROUND, units=Units.IN)
    assert isinstance(source, SyntheticSource)
    assert source.scene.units == "in"
    assert source.scene.ground_height == pytest.approx(250.0 / 25.4)
    assert SyntheticSource(scene).scene.units == "mm"


#: The default point target (0.5, 1.5, 11) in and two poses 1.5 in apart, in centimetres.
POINT_CM = "1.27, 3.81, 27.94"
POSES_CM = (("0", "0", "0"), ("3.81", "0", "-2.54"))


def _point_error_cm(out: Path) -> float:
    trials = analysis.run([out], jobs=1).trials
    assert list(trials["status"]) == ["ok"]
    assert set(trials["units"]) == {"cm"}
    return float(trials["err"].iloc[0])


def test_a_terminal_setup_in_cm_renders_the_scene_in_cm(tmp_path: Path) -> None:
    """``new --units cm --source synthetic`` at the terminal: the poses typed in cm place
    the camera in cm, so the point comes out where it is (it was about 17 cm off)."""
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE)
    out = tmp_path / "terminal.mcap"
    answers = []
    for x, y, z in POSES_CM:
        answers += [f"{x}, {y}, {z}", "", "a"]
    options = ["--method", "point", "--units", "cm", "--focal", "525", "--principal", "320,240"]
    options += ["--ground-truth", POINT_CM.replace(" ", ""), "--operator", "Bo", "--frames", "1"]
    result = runner.invoke(
        app,
        ["new", str(out), "--source", f"synthetic:{scene}", *options],
        input="\n".join([*answers, "n"]) + "\n",
    )
    assert result.exit_code == 0, result.output
    assert _point_error_cm(out) < 0.25


def test_a_page_setup_in_cm_renders_the_scene_in_cm(tmp_path: Path) -> None:
    """``new --ui --units cm --source synthetic``: the same through the web console."""
    scene = tmp_path / "scene.toml"
    scene.write_text(SCENE)
    out = tmp_path / "page.mcap"
    process, url, _ = start_console(out, "--units", "cm", "--source", f"synthetic:{scene}")
    try:
        client = httpx.Client(base_url=url, timeout=10)
        client.get("/")  # the page: the session's token
        setup = {"method": "point", "truth1": POINT_CM, "operator": "Ada"}
        assert client.post("/api/setup", json=setup).status_code == 200
        for x, y, z in POSES_CM:
            _wait_for(client, "pose")
            assert client.post("/api/pose", json={"x": x, "y": y, "z": z}).status_code == 200
            _wait_for(client, "decision")
            assert client.post("/api/decide", json={"decision": "accept"}).status_code == 200
        _wait_for(client, "pose")
        assert client.post("/api/decide", json={"decision": "quit"}).status_code == 200
        for _ in range(600):  # the file closed; the page stays until Ctrl-C
            if client.get("/api/state").json()["phase"] == "done":
                break
            time.sleep(0.05)
        else:
            raise AssertionError("the session never ended")
    finally:
        process.terminate()
        process.communicate(timeout=30)
    assert _point_error_cm(out) < 0.25


def _wait_for(client: httpx.Client, what: str) -> None:
    for _ in range(600):
        if client.get("/api/state").json()["waiting"] == what:
            return
        time.sleep(0.05)
    raise AssertionError(f"the console never waited for {what}")
