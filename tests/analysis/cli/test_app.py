"""The ``twopose-analyze`` application itself: its group options and the lines several
commands share (skipped inputs, notes), through typer's CliRunner."""

from __future__ import annotations

import pytest
from typer.testing import CliRunner

from analysis.cli import app
from analysis.cli.app import note, say_skipped
from twopose import __version__
from twopose.format.entries import FORMAT_VERSION

runner = CliRunner()


def test_version_names_the_package_and_the_session_format() -> None:
    result = runner.invoke(app, ["--version"])
    assert result.exit_code == 0
    assert result.stdout.strip() == f"twopose {__version__} (session format {FORMAT_VERSION})"


def test_no_arguments_shows_every_command() -> None:
    result = runner.invoke(app, [])
    commands = ("info", "run", "check", "compare", "rig", "sensitivity", "detect", "solve")
    missing = [c for c in commands if f"  {c} " not in result.output]
    assert missing == [], result.output


def test_skipped_results_files_are_named_on_stderr(capsys: pytest.CaptureFixture[str]) -> None:
    say_skipped(["out/results_a.mcap", "out/results_b.mcap"])
    captured = capsys.readouterr()
    assert captured.out == ""
    assert "skipped 2 results file(s)" in captured.err
    assert "out/results_a.mcap, out/results_b.mcap" in captured.err


def test_nothing_skipped_says_nothing(capsys: pytest.CaptureFixture[str]) -> None:
    say_skipped([])
    assert capsys.readouterr() == ("", "")


def test_a_note_is_marked_and_goes_to_stderr(capsys: pytest.CaptureFixture[str]) -> None:
    note("3 trials warned")
    assert capsys.readouterr() == ("", "note: 3 trials warned\n")
