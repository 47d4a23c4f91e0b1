"""``twopose-analyze run`` through typer's CliRunner: its summary, exit codes and refusals."""

from __future__ import annotations

import shutil
from pathlib import Path

import pytest
from typer.testing import CliRunner

from analysis.cli import app
from twopose.errors import EXIT_ERROR, EXIT_INTERRUPTED, EXIT_SOME_INPUTS_FAILED, EXIT_USAGE

runner = CliRunner()


def test_run_writes_results_and_prints_a_summary(tmp_path: Path, ground_session: Path) -> None:
    out = tmp_path / "res"
    result = runner.invoke(
        app, ["run", str(ground_session), "--out", str(out)], env={"COLUMNS": "200"}
    )
    assert result.exit_code == 0, result.output
    assert "ground" in result.output
    assert "2/2" in result.output
    for name in (
        "trials.csv",
        "summary.csv",
        "averaging.csv",
        "frames.csv",
        "errors.csv",
        "report.html",
    ):
        assert (out / name).exists()


def test_run_exit_code_when_some_inputs_fail(tmp_path: Path, ground_session: Path) -> None:
    shutil.copy(ground_session, tmp_path / "good.mcap")
    (tmp_path / "broken.mcap").write_bytes(b"MCAP? no")
    result = runner.invoke(
        app, ["run", str(tmp_path), "--out", str(tmp_path / "res"), "--jobs", "2"]
    )
    assert result.exit_code == EXIT_SOME_INPUTS_FAILED
    assert "broken.mcap" in result.output
    assert (tmp_path / "res" / "trials.csv").exists()


def test_run_missing_input_and_bad_options(tmp_path: Path) -> None:
    result = runner.invoke(app, ["run", str(tmp_path / "nothing")])
    assert result.exit_code == EXIT_ERROR
    assert "does not exist" in result.output
    assert runner.invoke(app, ["run", str(tmp_path), "--jobs", "0"]).exit_code == EXIT_USAGE
    assert runner.invoke(app, ["run", str(tmp_path), "--combine", "mode"]).exit_code == EXIT_USAGE


def test_a_ctrl_c_while_the_summary_prints_says_the_results_are_complete(
    tmp_path: Path, point_session: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """The outputs are committed before the summary is printed: a Ctrl-C then says so
    (exit 130), instead of a bare "interrupted" an analyst would read as nothing written."""
    import analysis.report.terminal

    def interrupted(*_args: object, **_kwargs: object) -> list[str]:
        # What Python's SIGINT handler raises there (a test worker may ignore the signal)
        raise KeyboardInterrupt

    monkeypatch.setattr(analysis.report.terminal, "closing_lines", interrupted)
    out = tmp_path / "out"
    result = runner.invoke(app, ["run", str(point_session), "--out", str(out), "--no-scene"])
    assert result.exit_code == EXIT_INTERRUPTED, result.output
    assert f"the results in {out} are complete" in result.output
    assert (out / "report.html").is_file()
    assert (out / "trials.csv").is_file()
