"""plan: plan files, checked and recorded unattended."""

from __future__ import annotations

import re
from pathlib import Path

import pytest
from typer.testing import CliRunner

from analysis.session.pipeline import analyse_session
from recorder.cli.app import app
from recorder.setup.plan import load_plan, record_plan
from recorder.sources.registry import SyntheticSource
from tests.helpers import write_video
from twopose.errors import EXIT_ERROR, InputValueError
from twopose.format.entries import FORMAT_VERSION, CaptureWindow
from twopose.format.reader import SessionReader
from twopose.methods.specs import Method

runner = CliRunner()


PLAN = """
method = "ground"
units = "in"
operator = "Ada"
frames = 3
ground_height = 9.625

[camera]
focal = 525.0
principal = [320.0, 240.0]

[[trials]]
ground_truth = [[1.91, 9.625, 8.375]]
poses = [{ t = [0.0, 0.0, 0.0] }, { t = [1.5, 0.0, -1.0] }]

[[trials]]
ground_truth = [[1.91, 9.625, 8.375]]
poses = [{ t = [-1.0, 0.0, 0.0] }, { t = [1.0, 0.0, 0.5], r_deg = [0.0, 0.0, 0.0] }]
"""


def test_plan_mode_records_a_session_analysis_reads(tmp_path: Path) -> None:
    plan = tmp_path / "plan.toml"
    plan.write_text(PLAN)
    out = tmp_path / "s.mcap"
    result = runner.invoke(app, ["new", str(out), "--plan", str(plan), "--source", "synthetic"])
    assert result.exit_code == 0, result.output
    assert "trial 2 pose 2: 3 frames, 3 detected, complete" in result.output
    assert "found at (" in result.output
    trials = analyse_session(out).trials
    assert list(trials["status"]) == ["ok", "ok"]
    # Typed poses are exact here, so only detection error remains (method 2 extrapolates).
    assert trials["err"].max() < 0.5


def test_adaptive_frames_stop_a_pose_once_more_would_not_help(tmp_path: Path) -> None:
    """The synthetic camera's frames scatter far under the glove's floor: with adaptive
    frames every pose stops at the least (3 of the plan's 12), said, and the analysis reads
    the file as any other; in a plan only (beside --plan the option is refused), and only
    as true or false."""
    plan = tmp_path / "plan.toml"
    plan.write_text(PLAN.replace("frames = 3", "frames = 12\nadaptive_frames = true"))
    out = tmp_path / "s.mcap"
    result = runner.invoke(app, ["new", str(out), "--plan", str(plan), "--source", "synthetic"])
    assert result.exit_code == 0, result.output
    said = "3 frames, 3 detected, complete (frames enough: another would not shrink the region)"
    assert result.output.count(said) == 4
    assert list(analyse_session(out).trials["status"]) == ["ok", "ok"]
    with SessionReader(out) as r:
        windows = [e for e in r.iter_entries() if isinstance(e, CaptureWindow)]
    assert [w.n_frames for w in windows] == [3, 3, 3, 3]
    beside = runner.invoke(
        app, ["new", str(tmp_path / "t.mcap"), "--plan", str(plan), "--adaptive-frames"]
    )
    assert beside.exit_code == EXIT_ERROR
    assert "adaptive_frames at its top" in beside.output
    plan.write_text(PLAN.replace("frames = 3", 'frames = 12\nadaptive_frames = "yes"'))
    with pytest.raises(InputValueError, match="adaptive_frames must be true or false"):
        load_plan(plan)


def test_plan_mode_with_a_source_that_runs_out(tmp_path: Path) -> None:
    plan = tmp_path / "plan.toml"
    plan.write_text(PLAN)
    out = tmp_path / "s.mcap"
    video = write_video(tmp_path / "v.avi", 4, size=(640, 480))
    result = runner.invoke(
        app, ["new", str(out), "--plan", str(plan), "--source", f"video:{video}"]
    )
    assert result.exit_code == EXIT_ERROR
    assert "trial 1 pose 2" in result.output
    assert "saved in" in result.output
    with SessionReader(out) as r:
        windows = [e for e in r.iter_entries() if isinstance(e, CaptureWindow)]
    assert [(w.pose, w.status) for w in windows] == [(1, "complete"), (2, "incomplete")]


@pytest.mark.parametrize(
    ("text", "message"),
    [
        ('method = "laser"\n', "method"),
        ('method = "point"\nunits = "furlong"\n', "units"),
        ('method = "ground"\n[[trials]]\nposes = [{t=[0,0,0]},{t=[1,0,0]}]\n', "ground_height"),
        ('method = "point"\n[[trials]]\nposes = [{t=[0,0,0]}]\n', "at least 2 poses"),
        ('method = "point"\n[[trials]]\nposes = [{t=[0,0]},{t=[1,0,0]}]\n', "poses[1].t"),
        (
            'method = "point"\n[[trials]]\nposes = [{t=[0,0,"a"]},{t=[1,0,0]}]\n',
            "t: camera centre z must be a number, got 'a'",
        ),
        (
            'method = "point"\n[[trials]]\nposes = [{t=[0,0,0]},{t=[9000,0,0]}]\n',
            "poses[2].t: camera centre x must be from -200 to 200 in, got 9000",
        ),
        ('method = "point"\nframes = 0\n', "frames"),
        ('method = "point"\n', "no [[trials]]"),
        (
            'method = "point"\n[camera]\nfocal = "big"\n'
            "[[trials]]\nposes = [{t=[0,0,0]},{t=[1,0,0]}]\n",
            "camera.focal",
        ),
        ("method = [", "not valid TOML"),
        ('method = "point"\nframe = 2\n', "unknown key frame"),
        ('method = "point"\noperater = "Ada"\n', "unknown key operater"),
        ('method = "point"\n[camera]\nfocus = 500\n', "unknown key camera.focus"),
        (
            'method = "point"\n[[trials]]\nposes = [{t=[0,0,0]},{t=[1,0,0]}]\ntruth = []\n',
            "unknown key trials[1].truth",
        ),
        (
            'method = "point"\n[[trials]]\nposes = [{t=[0,0,0], rot=[0,0,0]},{t=[1,0,0]}]\n',
            "unknown key trials[1].poses[1].rot",
        ),
        ('method = "point"\n[resolution]\ntranslate = 0.1\n', "unknown key resolution.translate"),
        (
            'method = "line"\n[[trials]]\nground_truth = [[0,0,1],[0,0,1]]\n'
            "poses = [{t=[0,0,0]},{t=[1,0,0]}]\n",
            "two points must differ",
        ),
        (
            'method = "ground"\nground_height = 9.625\n[[trials]]\n'
            "ground_truth = [[1.9, 5.0, 8.4]]\nposes = [{t=[0,0,0]},{t=[1,0,0]}]\n",
            "set keep_off_ground = true in this trial to keep it",
        ),
        (
            'method = "board"\n[board]\ninner_corners = [9, 101]\nsquare = 1\n'
            "first_corner = [0, 0, 20]\n",
            "inner corners rows must be a whole number from 3 to 100, got 101",  # as everywhere
        ),
        (
            'method = "point"\n[[trials]]\nposes = [{t=[0,0,0], r_deg=[0,200,0]},{t=[1,0,0]}]\n',
            "r_deg: rotation ry must be from -180 to 180 deg, got 200",
        ),
        (
            'method = "ground"\nground_height = 9.625\n[[trials]]\nkeep_off_ground = "yes"\n'
            "poses = [{t=[0,0,0]},{t=[1,0,0]}]\n",
            "keep_off_ground must be true or false",
        ),
        ('method = "point"\n[resolution]\ntranslation = -1\n', "resolution.translation"),
        (
            'method = "point"\n[[trials]]\nground_truth = [[1e300, 0, 1]]\n'
            "poses = [{t=[0,0,0]},{t=[1,0,0]}]\n",
            "ground_truth: ground truth x must be from -200 to 200 in, got 1e300",  # as written
        ),
        ('method = "point"\n[board]\nsquare = 1\n', "[board] is for a board session"),
        ('method = "board"\n[[trials]]\nposes = [{t=[0,0,0]},{t=[1,0,0]}]\n', "needs [board]"),
        ('method = "board"\n[board]\nsquare = 1\n', "board.first_corner is missing"),
        (
            'method = "board"\n[board]\ninner_corners = [9, 1]\nsquare = 1\n'
            "first_corner = [0, 0, 20]\n",
            "inner corners rows must be a whole number from 3 to 100, got 1",
        ),
        (
            'method = "board"\n[board]\ninner_corners = [9, 6]\nsquare = 1\n'
            "first_corner = [0, 0, 20]\nsize = 3\n",
            "unknown key board.size",
        ),
        (
            'method = "board"\n[board]\ninner_corners = [9, 6]\nsquare = 1\n'
            "first_corner = [0, 0, 20]\n[[trials]]\nground_truth = [[0, 0, 1]]\n"
            "poses = [{t=[0,0,0]},{t=[1,0,0]}]\n",
            "a board session's truth is its [board]",
        ),
    ],
)
def test_bad_plans_name_the_problem(tmp_path: Path, text: str, message: str) -> None:
    plan = tmp_path / "plan.toml"
    plan.write_text(text)
    with pytest.raises(InputValueError, match=re.escape(message)):
        load_plan(plan)


BOARD_PLAN = """
method = "board"
frames = 2

[board]
inner_corners = [9, 6]
square = 0.75
first_corner = [-3.0, 8.125, 24.0]

[[trials]]
poses = [
    { t = [0, 0, 0] }, { t = [2, 0, 0] }, { t = [-2, 0, 0] }, { t = [0, 0, -2] },
    { t = [2, 0, -2] }, { t = [-1, 0, 3] }, { t = [1, 0, -4] }, { t = [-2, 0, 2] },
]
"""


@pytest.mark.slow
def test_a_board_plan_records_a_board_session_rig_reads(tmp_path: Path) -> None:
    """The synthetic camera renders the board; the session holds the board, no truth; the
    analysis' rig finds the board in every capture, and run says it is not a measurement."""
    from analysis.rig.board import read_board_session

    plan = tmp_path / "board.toml"
    plan.write_text(BOARD_PLAN)
    out = tmp_path / "board.mcap"
    result = runner.invoke(app, ["new", str(out), "--plan", str(plan), "--source", "synthetic"])
    assert result.exit_code == 0, result.output
    with SessionReader(out) as reader:
        assert reader.info.method == "board"
        assert reader.info.board is not None
        assert reader.info.board.first_corner == (-3.0, 8.125, 24.0)
        assert reader.message_counts().get("/twopose/ground_truth", 0) == 0
    captures = read_board_session(out)
    assert captures.left_out == ()
    assert captures.observed_px.shape == (8, 54, 2)


def test_record_plan_python_api(tmp_path: Path) -> None:
    plan_file = tmp_path / "plan.toml"
    plan_file.write_text(PLAN.replace("frames = 3", "frames = 2"))
    plan = load_plan(plan_file)
    assert plan.cameras[0].intrinsics.fx == 525.0
    seen: list[str] = []
    summary = record_plan(
        plan,
        tmp_path / "s.mcap",
        SyntheticSource(None, Method.GROUND, realtime=False),
        on_frame=lambda f: seen.append(f.line()),
    )
    assert (summary.n_trials, summary.n_captures, summary.n_frames, summary.n_incomplete) == (
        2,
        4,
        8,
        0,
    )
    assert len(seen) == 8


@pytest.mark.slow
def test_ctrl_c_during_new_closes_the_session(tmp_path: Path) -> None:
    import os
    import signal
    import subprocess
    import sys

    plan = tmp_path / "plan.toml"
    plan.write_text(PLAN.replace("frames = 3", "frames = 200"))
    out = tmp_path / "s.mcap"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    proc = subprocess.Popen(
        [
            sys.executable,
            "-m",
            "recorder",
            "new",
            str(out),
            "--plan",
            str(plan),
            "--source",
            "synthetic",
        ],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        env=env,
        # A job started in the background by a non-interactive shell inherits SIGINT
        # ignored, and Python then never turns it into KeyboardInterrupt: restore it.
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    assert proc.stdout is not None
    for line in proc.stdout:  # the first capture is complete; the second is under way
        if line.startswith("trial 1 pose 1:"):
            break
    proc.send_signal(signal.SIGINT)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130
    assert "interrupted" in err
    with SessionReader(out) as r:  # closed cleanly: no recover needed
        windows = [e for e in r.iter_entries() if isinstance(e, CaptureWindow)]
    # The interrupt lands during pose 2's capture (kept, incomplete) or just before it.
    assert windows[0].status == "complete"
    assert len(windows) <= 2
    assert all(w.status == "incomplete" and "KeyboardInterrupt" in w.reason for w in windows[1:])


def test_a_calibration_s_sigma_is_recorded_with_its_camera(tmp_path: Path) -> None:
    """Format 1.2: a plan's calibration file carries its sigma into the session, where
    the reader attaches it to the camera (so the analysis can propagate it)."""
    cal = tmp_path / "cal.toml"
    cal.write_text(
        "width = 640\nheight = 480\nfx = 525.0\nfy = 525.0\ncx = 320.0\ncy = 240.0\n"
        "distortion = [0.0, 0.0, 0.0, 0.0, 0.0]\n[sigma]\nfx = 0.93\ncx = 1.07\n"
    )
    plan = tmp_path / "plan.toml"
    plan.write_text(
        PLAN.replace("focal = 525.0\nprincipal = [320.0, 240.0]", f'calibration = "{cal}"')
    )
    out = tmp_path / "s.mcap"
    result = runner.invoke(app, ["new", str(out), "--plan", str(plan), "--source", "synthetic"])
    assert result.exit_code == 0, result.output
    with SessionReader(out) as reader:
        assert reader.info.format_version == FORMAT_VERSION
        assert reader.info.intrinsics_sigma == {"cam0": {"fx": 0.93, "cx": 1.07}}
        assert reader.cameras["cam0"].intrinsics_sigma == {"fx": 0.93, "cx": 1.07}


def test_one_set_of_setup_rules_whatever_the_front_end(tmp_path: Path) -> None:
    """The terminal and the browser keep an off-ground truth when the operator confirms
    it; a plan does with keep_off_ground = true (before, a plan refused it outright). A
    plan's camera without a principal point has it at its image's centre, as the terminal
    and the browser assume (before, 320, 240 whatever its size)."""
    plan = tmp_path / "plan.toml"
    plan.write_text(
        'method = "ground"\nground_height = 9.625\n[camera]\nwidth = 1280\nheight = 720\n'
        "[[trials]]\nground_truth = [[1.9, 5.0, 8.4]]\nkeep_off_ground = true\n"
        "poses = [{t=[0,0,0]},{t=[1,0,0]}]\n"
    )
    loaded = load_plan(plan)
    assert loaded.trials[0].ground_truth == ((1.9, 5.0, 8.4),)
    intrinsics = loaded.cameras[0].intrinsics
    assert (intrinsics.cx, intrinsics.cy) == (640.0, 360.0)
    assert intrinsics.fx == 525.0


@pytest.mark.parametrize(("units", "factor"), [("in", 1.0), ("cm", 2.54), ("mm", 25.4)])
def test_the_default_placing_resolution_is_a_sixteenth_of_an_inch_in_any_units(
    tmp_path: Path, units: str, factor: float
) -> None:
    """A plan, the terminal and the page that say nothing of the resolution type poses to
    1/16 in in the session's units (was 1/16 of whatever unit: 1/16 mm in a mm session made
    every region about 12% too small and the stop rule end trials early)."""
    from recorder.setup.rules import PoseTyping
    from twopose.values.units import Units

    plan = tmp_path / "p.toml"
    plan.write_text(
        f'method = "point"\nunits = "{units}"\n[camera]\nfocal = 525.0\n'
        "[[trials]]\nground_truth = [[0.0, 0.0, 10.0]]\n"
        "poses = [{ t = [0.0, 0.0, 0.0] }, { t = [1.0, 0.0, 0.0] }]\n"
    )
    assert load_plan(plan).translation_resolution == pytest.approx(0.0625 * factor)
    assert PoseTyping().translation_sigma(Units(units)) == pytest.approx(0.0625 * factor)
    assert PoseTyping(translation_resolution=0.3).translation_sigma(Units(units)) == 0.3
