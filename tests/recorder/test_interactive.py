"""interactive: the guided procedure at the terminal, with scripted answers."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from numpy.typing import NDArray
from typer.testing import CliRunner

from analysis.session.pipeline import analyse_session
from recorder.cli.app import app
from recorder.procedure.capture import CaptureSettings
from recorder.procedure.terminal import Operator, record_interactive
from recorder.setup.rules import Setup
from recorder.sources.registry import SyntheticSource
from twopose.camera.model import Intrinsics
from twopose.errors import EXIT_ERROR, EXIT_INTERRUPTED
from twopose.format.entries import (
    CaptureDecision,
    CaptureWindow,
    GroundTruth,
    PoseEntry,
)
from twopose.format.reader import SessionReader
from twopose.methods.specs import Method
from twopose.values.units import Units

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
        "-1",  # the stop rule's precision: refused
        "",  # none: the trial has --poses poses
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
    assert out_text.count("not accepted") == 7
    assert "camera centre x must be from -200 to 200 in, got 1e9" in out_text
    assert "found at (" in out_text
    assert "1 trial (1 complete), 3 captures (2 accepted, 1 discarded; 0 incomplete)" in out_text
    assert out_text.count("wrote ") == 1  # the summary, once
    with SessionReader(out) as r:
        assert r.info.operator == "Ada"
        assert r.ground is not None
        entries = list(r.iter_entries())
    windows = [(e.trial, e.pose) for e in entries if isinstance(e, CaptureWindow)]
    assert windows == [(1, 1), (1, 1), (1, 2)]  # the redone capture is kept, discarded
    from twopose.format.entries import Note

    assert [e.text for e in entries if isinstance(e, Note)] == ["glove slipped a little"]
    trials = analyse_session(out).trials
    assert list(trials["status"]) == ["ok"]
    assert trials["err"].iloc[0] < 0.5
    # The trial's live result, printed with its last capture, before the decision (so a
    # degenerate one can still be redone): the analysis' own.
    lines = out_text.splitlines()
    (at,) = [i for i, x in enumerate(lines) if x.strip().startswith("result if accepted: trial 1")]
    line = lines[at]
    assert "[a]ccept" in " ".join(lines[at + 1 :])  # the decision is asked after it
    row = trials.iloc[0]
    assert f"x {row['x']:.3f} y {row['y']:.3f} z {row['z']:.3f} in" in line
    assert f"error {row['err']:.3f} in" in line


def test_interactive_options_skip_the_questions_and_undo_goes_back(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    answers = ["0, 0, 0", "", "a", "1, 0, 0", "", "u", "-1, 0, 0", "", "a", "1.5, 0, 0", "", "a"]
    answers += ["n"]  # no other trial
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
    # Pose 2 at x=1 was undone: pose 1 retyped at x=-1, then pose 2 at x=1.5.
    assert poses == [(1, 0.0), (2, 1.0), (1, -1.0), (2, 1.5)]
    trials = analyse_session(out).trials
    assert trials["status"].iloc[0] == "ok"
    assert trials["err"].iloc[0] < 0.05


class _CtrlCSource(SyntheticSource):
    """The synthetic camera (real rendering); Ctrl-C arrives at read number ``at``."""

    def __init__(self, at: int) -> None:
        super().__init__(None, Method.POINT, realtime=False)
        self.at, self.reads = at, 0

    def read(self, timeout_s: float = 2.0) -> NDArray[np.uint8]:
        self.reads += 1
        if self.reads == self.at:
            raise KeyboardInterrupt
        return super().read(timeout_s)


@pytest.mark.slow
def test_the_undo_then_interrupt_scenario_never_reports_a_wrong_ok(tmp_path: Path) -> None:
    """The issue's scenario: trial 2 pose 1 accepted at 0 0 0, pose 2 at 1.1 0 0 undone,
    pose 1 retyped as 0.5 0 0, Ctrl-C during that capture. Trial 2 must not be measured
    (it was reported ok with a 5 in error); trial 1 is measured from what was accepted."""
    answers = iter(
        [
            *("0 0 0", "", "a", "1.1 0 0", "", "a", "y"),  # trial 1
            *("0 0 0", "", "a", "1.1 0 0", "", "u", "0.5 0 0", ""),  # trial 2, then Ctrl-C
        ]
    )
    said: list[str] = []
    op = Operator(lambda q, d: next(answers) or d, said.append)
    out = tmp_path / "s.mcap"
    summary = record_interactive(
        out,
        _CtrlCSource(at=10),  # 2 frames a capture: read 10 is the retyped pose's second
        op,
        setup=Setup(
            method=Method.POINT,
            units=Units.IN,
            intrinsics=Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0),
            plane_offset=None,
            ground_truth=((0.5, 1.5, 11.0),),
            operator="",
        ),
        capture=CaptureSettings(frames=2),
    )
    assert summary.interrupted
    assert next(answers, None) is None  # every answer was used
    trials = analyse_session(out).trials.set_index("trial")
    assert trials.loc[1, "status"] == "ok"
    assert float(trials["err"].loc[1]) < 0.05
    assert trials.loc[2, "status"] == "incomplete"
    assert "undone by capture 4" in str(trials.loc[2, "reason"])
    assert "interrupted" in str(trials.loc[2, "reason"])


SETUP_OPTIONS = [
    "--source",
    "synthetic",
    "--units",
    "in",
    "--focal",
    "525",
    "--principal",
    "320,240",
]
POINT_OPTIONS = [*SETUP_OPTIONS, "--frames", "1", "--method", "point", "--operator", "Bo"]
GROUND_OPTIONS = [*SETUP_OPTIONS, "--frames", "1", "--method", "ground", "--operator", "Bo"]
GROUND_OPTIONS += ["--ground-height", "9.625"]


def test_an_existing_file_is_refused_before_the_first_question(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    out.write_bytes(b"an earlier session")
    result = runner.invoke(app, ["new", str(out), "--source", "synthetic"], input="point\n")
    assert result.exit_code == EXIT_ERROR
    assert "already exists" in result.output
    assert "method" not in result.output  # no question was asked
    assert out.read_bytes() == b"an earlier session"


def test_identical_line_points_are_refused_at_the_prompt(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    answers = ["line", "0, 0, 10", "0, 0, 10", "1, 0, 10", "Ada", ""]  # then the input ends
    result = runner.invoke(
        app,
        ["new", str(out), *SETUP_OPTIONS],
        input="\n".join(answers) + "\n",
    )
    assert "a line needs two different points" in result.output
    assert result.exit_code == EXIT_INTERRUPTED  # the input ended: like Ctrl-C
    assert "interrupted" in result.output
    # Ended at the first pose's question: no empty file is left to block the name.
    assert "nothing was recorded: no session file written" in result.output
    assert not out.exists()


@pytest.mark.parametrize("keep", ["y", "n"])
def test_a_method_2_truth_off_the_ground_is_questioned(tmp_path: Path, keep: str) -> None:
    out = tmp_path / "s.mcap"
    answers = ["1.9, 5, 8.4", keep] + (["1.9, 9.625, 8.4"] if keep == "n" else [])
    answers += [""]  # no stop rule
    answers += ["0, 0, 0", "", "a", "1.5, 0, -1", "", "a", "n"]
    result = runner.invoke(
        app,
        ["new", str(out), *GROUND_OPTIONS],
        input="\n".join(answers) + "\n",
    )
    assert result.exit_code == 0, result.output
    assert "warning: the ground truth (1.9, 5, 8.4) has y = 5 in" in result.output  # as typed
    with SessionReader(out) as r:
        (truth,) = [e for e in r.iter_entries() if isinstance(e, GroundTruth)]
    assert truth.points_grid[0][1] == (5.0 if keep == "y" else 9.625)


TRUTH = ["--ground-truth", "0.5,1.5,11"]


def test_the_stop_rule_is_asked_with_the_setup_and_ends_the_trial(tmp_path: Path) -> None:
    """Asked last when the setup is asked (the option skips it): a trial whose region is
    within the answer is complete at its second pose."""
    out = tmp_path / "s.mcap"
    answers = ["0.5, 1.5, 11", "0", "5"]  # the truth; the precision: 0 refused, then 5 in
    answers += ["0, 0, 0", "", "a", "1.5, 0, 0", "", "a", "n"]
    result = runner.invoke(
        app,
        ["new", str(out), *POINT_OPTIONS],
        input="\n".join(answers) + "\n",
    )
    assert result.exit_code == 0, result.output
    assert "stop a trial when its 95% region is within (in; none: no stop rule)" in result.output
    assert (
        "target precision must be more than 0 and at most 100 in, got 0; or none for no "
        "stop rule" in result.output
    )
    assert "<= 5: trial complete" in result.output
    assert "1 trial (1 complete), 2 captures (2 accepted" in result.output
    # Issue 46: after the suggestion, the three best poses of the map, each with its value;
    # issue 55: with one pose each one's worst regret over the depths the suggestion
    # weighs, so that the suggestion is the first listed.
    said = result.output.split("guidance: next pose:")[1].splitlines()
    assert said[1].strip() == (
        "the 3 best poses of the map (worst regret for a target 8-30 in along the first ray):"
    )
    assert all(" at its worst depth" in line and line.strip().startswith("x ")
               for line in said[2:5])  # fmt: skip
    assert len(set(said[2:5])) == 3
    where = said[0].split(" in (")[0].strip()  # "x 3, y 0, z 3"
    assert said[2].strip().startswith(where + " in: ")
    assert said[2].endswith("(the suggestion)")
    given = runner.invoke(
        app,
        ["new", str(tmp_path / "t.mcap"), *POINT_OPTIONS, "--target-precision", "5", *TRUTH],
        input="\n".join(["0, 0, 0", "", "a", "1.5, 0, 0", "", "a", "n"]) + "\n",
    )
    assert given.exit_code == 0, given.output
    assert "stop a trial" not in given.output
    assert "<= 5: trial complete" in given.output


def test_undo_at_the_first_pose_says_there_is_nothing_to_undo(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    answers = ["0, 0, 0", "", "u", "a", "1.1, 0, 0", "", "a", "n"]
    result = runner.invoke(
        app,
        ["new", str(out), *POINT_OPTIONS, "--ground-truth", "0.5,1.5,11"],
        input="\n".join(answers) + "\n",
    )
    assert result.exit_code == 0, result.output
    assert "nothing to undo: pose 1 is the first pose of trial 1" in result.output
    assert "1 trial (1 complete), 2 captures (2 accepted, 0 discarded" in result.output


def test_ctrl_c_at_a_prompt_closes_the_file_prints_the_summary_once_and_exits_130(
    tmp_path: Path,
) -> None:
    out = tmp_path / "s.mcap"
    answers = ["0, 0, 0", "", "a", "1.1, 0, 0", ""]  # the input ends at the decision
    result = runner.invoke(
        app,
        ["new", str(out), *POINT_OPTIONS, "--ground-truth", "0.5,1.5,11"],
        input="\n".join(answers) + "\n",
    )
    assert result.exit_code == EXIT_INTERRUPTED, result.output
    assert result.output.count("wrote ") == 1
    assert "2 captures (1 accepted, 1 discarded" in result.output
    with SessionReader(out) as r:  # closed: no recover needed
        decisions = [e for e in r.iter_entries() if isinstance(e, CaptureDecision)]
    assert [(d.decision, d.reason) for d in decisions] == [
        ("accept", ""),
        ("discard", "interrupted (Ctrl-C)"),
    ]


def test_a_board_session_asks_for_its_board_and_no_truth(tmp_path: Path) -> None:
    out = tmp_path / "board.mcap"
    answers = ["9by6", "9x6", "0.75", "-3, 8.125", "-3, 8.125, 24"]  # two typos, refused
    for t in ("0, 0, 0", "2, 0, 0", "0, 0, -2"):
        answers += [t, "", "a"]
    answers += ["n"]  # no other trial
    options = ["--source", "synthetic", "--frames", "1", "--method", "board", "--poses", "3"]
    options += ["--units", "in", "--focal", "525", "--principal", "320,240", "--operator", "Bo"]
    result = runner.invoke(app, ["new", str(out), *options], input="\n".join(answers) + "\n")
    assert result.exit_code == 0, result.output
    assert "COLSxROWS" in result.output  # the typo's refusal, then asked again
    assert "ground truth" not in result.output
    with SessionReader(out) as r:
        assert r.info.board is not None
        assert (r.info.board.inner_corners, r.info.board.square) == ((9, 6), 0.75)
        assert r.info.board.first_corner == (-3.0, 8.125, 24.0)
        poses = [e.t_grid for e in r.iter_entries() if isinstance(e, PoseEntry)]
    assert poses == [(0.0, 0.0, 0.0), (2.0, 0.0, 0.0), (0.0, 0.0, -2.0)]


@pytest.mark.parametrize(
    ("options", "message", "code"),
    [
        (
            ["--method", "point", "--board", "9x6"],
            "for a board session (--method board) only",
            EXIT_ERROR,
        ),
        (
            ["--method", "board", "--board", "9x6"],
            "give --square, --board-corner with --board",
            EXIT_ERROR,
        ),
        (  # an option's text that is not what it says: a malformed command line
            ["--method", "board", "--board", "9", "--square", "1", "--board-corner", "0,0,20"],
            "COLSxROWS",
            2,
        ),
    ],
)
def test_board_options_that_do_not_make_a_board_are_refused_before_recording(
    tmp_path: Path, options: list[str], message: str, code: int
) -> None:
    out = tmp_path / "s.mcap"
    result = runner.invoke(app, ["new", str(out), "--source", "synthetic", *options])
    assert result.exit_code == code, result.output
    assert message in result.output
    assert not out.exists()
