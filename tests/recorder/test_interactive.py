"""interactive: the guided procedure at the terminal, with scripted answers."""

from __future__ import annotations

from pathlib import Path

from typer.testing import CliRunner

from analysis.pipeline import analyse_session
from recorder.cli import app
from twopose.format.entries import CaptureWindow, PoseEntry
from twopose.format.reader import SessionReader

runner = CliRunner()


def test_interactive_procedure_with_valid_and_invalid_answers(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    answers = [
        "ground",  # method
        "",  # units: default in
        "abc",  # focal: refused
        "525",
        "",  # principal: default 320, 240
        "-5",  # ground height: refused
        "9.625",
        "1.91, 9.625",  # ground truth: refused (two numbers)
        "1.91, 9.625, 8.375",
        "Ada",  # operator
        "0, 0, 0",  # trial 1 pose 1
        "",  # rotation: default 0, 0, 0
        "r",  # redo pose 1
        "0 0 0",
        "",
        "n",  # a note, then accept
        "glove slipped a little",
        "a",
        "nan, 0, 0",  # pose 2: refused (not finite)
        "1e9, 0, 0",  # refused (implausible)
        "1.5, 0, -1",
        "",
        "x",  # refused choice
        "a",
        "n",  # no other trial
    ]
    result = runner.invoke(
        app,
        ["new", str(out), "--source", "synthetic", "--frames", "2"],
        input="\n".join(answers) + "\n",
    )
    assert result.exit_code == 0, result.output
    out_text = result.output
    assert out_text.count("not accepted") == 6
    assert "implausibly large" in out_text
    assert "found at (" in out_text
    assert "finished: 1 trial(s), 3 capture(s)" in out_text
    with SessionReader(out) as r:
        assert r.info.operator == "Ada"
        assert r.ground is not None
        entries = list(r.iter_entries())
    windows = [(e.trial, e.pose) for e in entries if isinstance(e, CaptureWindow)]
    assert windows == [(1, 1), (1, 1), (1, 2)]  # the redo is kept; the later one counts
    from twopose.format.entries import Note

    assert [e.text for e in entries if isinstance(e, Note)] == ["glove slipped a little"]
    trials = analyse_session(out).trials
    assert list(trials["status"]) == ["ok"]
    assert trials["err"].iloc[0] < 0.5


def test_interactive_options_skip_the_questions_and_undo_goes_back(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    answers = ["0, 0, 0", "", "a", "1, 0, 0", "", "u", "-1, 0, 0", "", "a", "1.5, 0, 0", "", "q"]
    result = runner.invoke(
        app,
        [
            "new",
            str(out),
            "--source",
            "synthetic",
            "--frames",
            "1",
            "--method",
            "point",
            "--units",
            "in",
            "--focal",
            "525",
            "--principal",
            "320,240",
            "--ground-truth",
            "0.5,1.5,11",
            "--operator",
            "Bo",
        ],
        input="\n".join(answers) + "\n",
    )
    assert result.exit_code == 0, result.output
    with SessionReader(out) as r:
        poses = [(e.pose, e.t_grid[0]) for e in r.iter_entries() if isinstance(e, PoseEntry)]
    # Pose 2 at x=1 was undone: pose 1 retyped at x=-1, then pose 2 at x=1.5; q finished.
    assert poses == [(1, 0.0), (2, 1.0), (1, -1.0), (2, 1.5)]
    trials = analyse_session(out).trials
    assert trials["status"].iloc[0] == "ok"
    assert trials["err"].iloc[0] < 0.05
