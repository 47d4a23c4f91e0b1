"""console: the run's answer fits an 80-column terminal and stays whole in a pipe."""

from __future__ import annotations

from pathlib import Path

import pytest
from typer.testing import CliRunner

from analysis.batch.runner import run
from analysis.cli import app
from analysis.report.terminal import summary_lines, wrap_phrases

SESSIONS = Path(__file__).resolve().parents[2] / "sessions"


@pytest.fixture(scope="module")
def sample_run() -> object:
    return run([SESSIONS / "stress_method2_ground.mcap", SESSIONS / "stress_line.mcap"])


def test_at_80_columns_nothing_is_cut(sample_run: object) -> None:
    lines = summary_lines(sample_run.trials, sample_run.summary, width=80)  # type: ignore[attr-defined]
    assert max(len(line) for line in lines) <= 80
    text = " ".join(line.strip() for line in lines)
    assert "errors in inches" in text
    for name in ("stress_method2_ground.mcap (ground, in)", "stress_line.mcap (line, in)"):
        assert name in text  # whole names, no ellipsis
    assert "…" not in text
    assert any(line.startswith("ground ") for line in lines)
    assert any(line.startswith("line ") for line in lines)


def test_piped_output_keeps_every_session_on_one_line(tmp_path: Path) -> None:
    result = CliRunner().invoke(
        app, ["run", str(SESSIONS / "stress_line.mcap"), "--out", str(tmp_path / "o"), "--no-scene"]
    )
    assert result.exit_code == 0, result.output
    (line,) = [
        x for x in result.stdout.splitlines() if x.startswith("  stress_line.mcap (line, in):")
    ]
    assert "rmse" in line
    assert "within 1 in:" in line  # the share within 1 names its unit
    assert "left out of these statistics" in result.stdout  # the line session has warnings


def test_lines_break_between_phrases_never_inside_one(sample_run: object) -> None:
    lines = summary_lines(sample_run.trials, sample_run.summary, width=60)  # type: ignore[attr-defined]
    session_lines = lines[lines.index("per session:") + 1 :]
    assert len(session_lines) > len(sample_run.summary)  # type: ignore[attr-defined]  # wrapped
    for line in session_lines:
        assert len(line) <= 60
        for label in ("rmse", "median", "max", "bias x", "within 1 in:"):
            if line.rstrip().endswith(label):
                raise AssertionError(f"{label!r} cut from its value: {line!r}")
    assert wrap_phrases(["a b", "c d"], None, indent="  ") == ["  a b c d"]
    assert wrap_phrases(["aaaa bbbb", "cc dd"], 10) == ["aaaa bbbb", "  cc dd"]
