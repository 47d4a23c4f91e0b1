"""Frame sources, capturing a pose, plan files and plan mode."""

from __future__ import annotations

import re
from pathlib import Path

import cv2
import numpy as np
import pytest
from typer.testing import CliRunner

from analysis.pipeline import analyse_session
from recorder.camera import Intrinsics
from recorder.cli import app
from recorder.errors import EXIT_ERROR, InputValueError
from recorder.procedure import capture_pose, load_plan, record_plan
from recorder.session import (
    Camera,
    CaptureWindow,
    PoseEntry,
    SessionInfo,
    SessionReader,
    SessionWriter,
)
from recorder.sources import ImagesSource, SourceError, SyntheticSource, VideoSource, open_source

runner = CliRunner()


def _video(path: Path, n: int, size: tuple[int, int] = (64, 48), step: int = 20) -> Path:
    w = cv2.VideoWriter(str(path), cv2.VideoWriter_fourcc(*"MJPG"), 30.0, size)
    assert w.isOpened()
    for i in range(n):
        w.write(np.full((size[1], size[0], 3), step * i, np.uint8))
    w.release()
    return path


def test_video_source_reads_in_order_then_says_it_ended(tmp_path: Path) -> None:
    with VideoSource(_video(tmp_path / "v.avi", 4)) as src:
        assert (src.info.width, src.info.height) == (64, 48)
        means = [src.read().mean() for _ in range(4)]
        assert means == sorted(means)
        with pytest.raises(SourceError, match="no more frames"):
            src.read()


def test_images_source(tmp_path: Path) -> None:
    for i in range(3):
        cv2.imwrite(str(tmp_path / f"{i:02d}.png"), np.full((10, 20, 3), i * 50, np.uint8))
    (tmp_path / "notes.txt").write_text("ignored")
    with ImagesSource(tmp_path) as src:
        assert (src.info.width, src.info.height) == (20, 10)
        assert [int(src.read()[0, 0, 0]) for _ in range(3)] == [0, 50, 100]
        with pytest.raises(SourceError, match="no more images"):
            src.read()


def test_synthetic_source_renders_the_typed_pose() -> None:
    with SyntheticSource(None, "point", realtime=False) as src:
        src.set_pose((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        a = src.read()
        src.set_pose((1.5, 0.0, 0.0), (0.0, 0.0, 0.0))
        b = src.read()
    from analysis.detect import detect_dot

    da, db = detect_dot(a), detect_dot(b)
    assert da.found
    assert db.found
    # Moving the camera +1.5 in along x moves the dot left by f * 1.5 / z = 525 * 1.5 / 11 px.
    assert da.centroid_px[0] - db.centroid_px[0] == pytest.approx(525 * 1.5 / 11.0, abs=0.3)


@pytest.mark.parametrize(
    ("spec", "message"),
    [
        ("camera:99", "did not open"),
        ("camera:x", "must be a number"),
        ("video:/nonexistent.avi", "does not exist"),
        ("images:/nonexistent", "does not exist"),
        ("webcam", "unknown source"),
    ],
)
def test_bad_sources_say_what_is_wrong(spec: str, message: str) -> None:
    with pytest.raises(SourceError, match=message):
        open_source(spec).open()


def test_a_source_that_stops_mid_capture_leaves_an_incomplete_capture(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    cam = Camera("cam0", Intrinsics(64, 48, 50.0, 50.0, 32.0, 24.0))
    with (
        VideoSource(_video(tmp_path / "v.avi", 3)) as src,
        SessionWriter(out, SessionInfo("point", "in"), [cam]) as w,
    ):
        result = capture_pose(w, src, PoseEntry(1, 1, "cam0", (0.0, 0.0, 0.0)), 5, target="dot")
    assert not result.complete
    assert result.n_frames == 3
    assert "no more frames" in result.reason
    assert len(result.feedback) == 3
    with SessionReader(out) as r:  # the session stays valid
        (window,) = [e for e in r.iter_entries() if isinstance(e, CaptureWindow)]
    assert (window.status, window.n_frames) == ("incomplete", 3)
    assert "no more frames" in window.reason


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


def test_plan_mode_with_a_source_that_runs_out(tmp_path: Path) -> None:
    plan = tmp_path / "plan.toml"
    plan.write_text(PLAN)
    out = tmp_path / "s.mcap"
    video = _video(tmp_path / "v.avi", 4)
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
        ('method = "point"\n[[trials]]\nposes = [{t=[0,0,"a"]},{t=[1,0,0]}]\n', "finite numbers"),
        (
            'method = "point"\n[[trials]]\nposes = [{t=[0,0,0]},{t=[9000,0,0]}]\n',
            "implausibly large",
        ),
        ('method = "point"\nframes = 0\n', "frames"),
        ('method = "point"\n', "no [[trials]]"),
        (
            'method = "point"\n[camera]\nfocal = "big"\n'
            "[[trials]]\nposes = [{t=[0,0,0]},{t=[1,0,0]}]\n",
            "camera.focal",
        ),
        ("method = [", "not valid TOML"),
    ],
)
def test_bad_plans_name_the_problem(tmp_path: Path, text: str, message: str) -> None:
    plan = tmp_path / "plan.toml"
    plan.write_text(text)
    with pytest.raises(InputValueError, match=re.escape(message)):
        load_plan(plan)


def test_record_plan_python_api(tmp_path: Path) -> None:
    plan_file = tmp_path / "plan.toml"
    plan_file.write_text(PLAN.replace("frames = 3", "frames = 2"))
    plan = load_plan(plan_file)
    assert plan.cameras[0].intrinsics.fx == 525.0
    seen: list[str] = []
    summary = record_plan(
        plan,
        tmp_path / "s.mcap",
        SyntheticSource(None, "ground", realtime=False),
        on_frame=lambda f: seen.append(f.line()),
    )
    assert (summary.n_trials, summary.n_captures, summary.n_frames, summary.n_incomplete) == (
        2,
        4,
        8,
        0,
    )
    assert len(seen) == 8


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
    from recorder.session import Note

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


def test_a_late_reader_of_a_paced_source_drops_frames_and_they_are_counted(tmp_path: Path) -> None:
    import time

    out = tmp_path / "s.mcap"
    cam = Camera("cam0", Intrinsics(640, 480, 525.0, 525.0, 320.0, 240.0))
    with (
        SyntheticSource(None, "point") as src,
        SessionWriter(out, SessionInfo("point", "in"), [cam]) as w,
    ):
        src.read()
        time.sleep(0.2)  # six frame intervals at 30 fps
        src.read()  # a camera would have moved on meanwhile
        assert src.dropped >= 4
        before = src.dropped
        result = capture_pose(
            w,
            src,
            PoseEntry(1, 1, "cam0", (0.0, 0.0, 0.0)),
            3,
            target="dot",
            on_frame=lambda fb: time.sleep(0.1),  # a slow consumer: ~3 intervals a frame
        )
    assert result.dropped >= 4
    assert src.dropped - before == result.dropped
    assert len(result.overhead_s) == 3
    with SessionReader(out) as r:
        (window,) = [e for e in r.iter_entries() if isinstance(e, CaptureWindow)]
    assert window.dropped_frames == result.dropped


def test_a_paced_video_skips_the_frames_a_late_reader_missed(tmp_path: Path) -> None:
    import time

    with VideoSource(_video(tmp_path / "v.avi", 30, step=8), realtime=True) as src:
        first = src.read().mean()
        time.sleep(0.12)  # ~3.6 frame intervals at 30 fps
        second = src.read().mean()
    assert src.dropped >= 2
    assert second - first == pytest.approx(8 * (src.dropped + 1), abs=3)


def test_camera_source_reports_a_device_that_stops_delivering(tmp_path: Path) -> None:
    """The capture thread's end-of-stream path, driven by a real capture that runs dry."""
    from recorder.sources import CameraSource

    with CameraSource(str(_video(tmp_path / "v.avi", 3))) as cam:
        # A file delivers faster than a camera: the grabber keeps the newest frames, as it
        # does for a camera, so how many arrive depends on timing; none is lost uncounted.
        frames: list[np.ndarray] = []

        def drain() -> None:
            for _ in range(4):
                frames.append(cam.read(timeout_s=2.0))

        with pytest.raises(SourceError, match="stopped delivering"):
            drain()
        assert frames
        assert all(f.shape == (48, 64, 3) for f in frames)
        assert len(frames) + cam.dropped == 3


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
