"""twopose-record through typer's CliRunner: output, files and exit codes."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

from typer.testing import CliRunner

from recorder.cli.app import app
from twopose.errors import EXIT_ERROR, EXIT_USAGE
from twopose.format.reader import SessionReader

runner = CliRunner()


def test_simulate_writes_a_session(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    result = runner.invoke(
        app,
        [
            "simulate",
            str(out),
            "--method",
            "line",
            "--trials",
            "1",
            "--frames",
            "2",
            "--seed",
            "4",
            "--pose-noise",
            "0.05",
        ],
    )
    assert result.exit_code == 0, result.output
    assert "1 trial, 2 poses, 4 frames" in result.output
    with SessionReader(out) as r:
        assert r.info.method == "line"
        assert "pose_noise=0.05" in r.info.notes


def test_simulate_refuses_to_overwrite(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    out.write_bytes(b"keep me")
    result = runner.invoke(
        app, ["simulate", str(out), "--method", "point", "--trials", "1", "--frames", "1"]
    )
    assert result.exit_code == EXIT_ERROR
    assert "never overwrites" in result.output
    assert out.read_bytes() == b"keep me"


def test_simulate_bad_scene_is_a_clear_error(tmp_path: Path) -> None:
    scene = tmp_path / "scene.toml"
    scene.write_text("[finger]\ncolour = 'blue'\n")
    result = runner.invoke(
        app, ["simulate", str(tmp_path / "s.mcap"), "--method", "ground", "--scene", str(scene)]
    )
    assert result.exit_code == EXIT_ERROR
    assert "finger.colour" in result.output
    assert "Traceback" not in result.output


def test_simulate_usage_errors(tmp_path: Path) -> None:
    result = runner.invoke(app, ["simulate", str(tmp_path / "s.mcap"), "--method", "laser"])
    assert result.exit_code == EXIT_USAGE
    result = runner.invoke(
        app, ["simulate", str(tmp_path / "s.mcap"), "--method", "point", "--trials", "0"]
    )
    assert result.exit_code == EXIT_USAGE


def test_python_dash_m_recorder_is_the_same_cli() -> None:
    result = subprocess.run(
        [sys.executable, "-m", "recorder", "simulate", "--help"],
        capture_output=True,
        text=True,
        check=False,
    )
    assert result.returncode == 0
    assert "--pose-noise" in result.stdout
