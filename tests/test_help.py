"""Help text of both command lines: plain, wrapped at words within 80 columns, and the
``solve`` request documented well enough to run its own example."""

from __future__ import annotations

import json
import re

import pytest
import typer
from typer.testing import CliRunner

from analysis.cli import app as analyze_app
from recorder.cli.app import app as record_app

runner = CliRunner()


def _commands(app: typer.Typer) -> list[str]:
    group = typer.main.get_command(app)
    commands = getattr(group, "commands", {})
    assert commands
    return sorted(commands)


CASES = [(record_app, c) for c in _commands(record_app)] + [
    (analyze_app, c) for c in _commands(analyze_app)
]


def test_both_command_lines_have_their_commands() -> None:
    assert {"check", "compare", "run", "solve"} <= set(_commands(analyze_app))
    assert {"new", "simulate", "recover"} <= set(_commands(record_app))


@pytest.mark.parametrize(("app", "command"), CASES, ids=[c for _, c in CASES])
def test_help_fits_80_columns_and_breaks_at_words(app: typer.Typer, command: str) -> None:
    result = runner.invoke(app, [command, "--help"], env={"COLUMNS": "80"}, terminal_width=80)
    assert result.exit_code == 0, result.output
    lines = result.output.splitlines()
    assert lines[0].startswith("Usage:")
    assert max(len(line) for line in lines) <= 80
    assert "…" not in result.output  # nothing cut
    assert "╭" not in result.output  # no boxes squeezing the text
    for name in re.findall(r"--[a-z][a-z-]+", result.output):
        assert name in result.output.replace("\n", " ")  # option names never split


def test_solve_help_documents_the_request_and_its_example_runs() -> None:
    result = runner.invoke(analyze_app, ["solve", "--help"], terminal_width=80)
    text = result.output
    for field in (
        '"views"',
        '"K"',
        '"pose"',
        '"t"',
        '"r_deg"',
        '"px"',
        '"P"',
        '"line"',
        '"theta_deg"',
        '"segment_px"',
        '"ground_y"',
        '"estimator"',
        '"sigma_px"',
    ):
        assert field in text, field
    example = text[text.index("echo '") + len("echo '") : text.index("' | twopose-analyze")]
    request = json.loads(" ".join(example.split()))
    solved = runner.invoke(analyze_app, ["solve", "point"], input=json.dumps(request))
    assert solved.exit_code == 0, solved.output
    answer = json.loads(solved.output)
    assert answer["status"] == "ok"
    assert answer["point"] == pytest.approx([0.5, 1.5, 11.0], abs=1e-3)
