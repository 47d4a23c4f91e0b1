"""twopose-analyze info: describe sessions, list failures, exit codes."""

from __future__ import annotations

import shutil
import subprocess
import sys
from pathlib import Path

from typer.testing import CliRunner

from analysis.cli import app
from twopose.camera.model import Camera, Intrinsics
from twopose.errors import EXIT_ERROR, EXIT_SOME_INPUTS_FAILED
from twopose.format.entries import Note, SessionInfo
from twopose.format.trials import describe_session
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.values.text import first_control
from twopose.values.units import Units

runner = CliRunner()


def test_info_describes_a_folder_recursively(
    tmp_path: Path, ground_session: Path, point_session: Path
) -> None:
    (tmp_path / "a" / "b").mkdir(parents=True)
    shutil.copy(ground_session, tmp_path / "a" / "g.mcap")
    shutil.copy(point_session, tmp_path / "a" / "b" / "p.mcap")
    result = runner.invoke(app, ["info", str(tmp_path)], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    assert "2 session(s)" in result.output
    assert "ground (sim)" in result.output
    assert "point (sim)" in result.output


def test_info_lists_a_bad_file_and_exits_nonzero(
    tmp_path: Path, ground_session: Path, point_session: Path
) -> None:
    shutil.copy(ground_session, tmp_path / "good.mcap")
    # Another session cut short (one of good.mcap would be its copy, not a failure).
    (tmp_path / "bad.mcap").write_bytes(point_session.read_bytes()[:5000])
    result = runner.invoke(app, ["info", str(tmp_path)], env={"COLUMNS": "200"})
    assert result.exit_code == EXIT_SOME_INPUTS_FAILED
    assert "1 session(s)" in result.output
    assert "bad.mcap" in result.output
    assert "recover" in result.output


def test_info_on_a_missing_path_is_an_error(tmp_path: Path) -> None:
    result = runner.invoke(app, ["info", str(tmp_path / "nothing")])
    assert result.exit_code == EXIT_ERROR
    assert "does not exist" in result.output


def test_info_on_an_empty_folder_says_so(tmp_path: Path) -> None:
    result = runner.invoke(app, ["info", str(tmp_path)])
    assert result.exit_code == EXIT_SOME_INPUTS_FAILED
    assert "no session files" in result.output


def test_describe_session_counts(ground_session: Path) -> None:
    o = describe_session(ground_session)
    assert (o.n_trials, o.n_poses, o.n_captures, o.n_frames) == (2, 4, 4, 12)
    assert o.n_incomplete_captures == 0
    assert o.message_counts["/twopose/camera/cam0/image"] == 12
    assert o.message_counts["/tf"] == 4


def test_python_dash_m_analysis() -> None:
    result = subprocess.run(
        [sys.executable, "-m", "analysis", "--help"], capture_output=True, text=True, check=False
    )
    assert result.returncode == 0
    assert "info" in result.stdout


def test_info_shows_control_characters_in_notes_escaped_not_obeyed(tmp_path: Path) -> None:
    """A note is typed text in a file anyone may hand us: an ESC sequence (clear the
    screen), a bell, a carriage return or a bidi override is printed as its escape."""
    path = tmp_path / "s.mcap"
    hostile = "ok\x1b[2J\x07\rfake\u202eevil"
    cam = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=32, height=24, fx=30.0, fy=30.0, cx=16.0, cy=12.0),
    )
    with SessionWriter(
        path,
        SessionInfo(method=Method.POINT, units=Units.IN),
        [cam],
        image_format="png",
        start_ns=0,
    ) as w:
        w.write_note(Note(text=hostile, trial=None), 1)
        w.write_note(Note(text="plain, né à Zoë 北京", trial=1), 2)
    result = runner.invoke(app, ["info", str(path)], env={"COLUMNS": "200"})
    assert result.exit_code == 0, result.output
    assert "session: ok\\x1b[2J\\x07\\rfake\\u202eevil" in result.output
    assert "trial 1: plain, né à Zoë 北京" in result.output  # printable text as it is
    assert not any(first_control(line) for line in result.output.splitlines())
