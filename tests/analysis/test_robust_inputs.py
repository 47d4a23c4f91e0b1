"""Valid but unusual sessions never cost a run its report: no ground truth, errors that
are all unknown, an absurd truth, a trial number recorded twice."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pandas as pd
import pytest

from analysis.batch.runner import run
from analysis.results import AnalysisOptions
from recorder.setup.plan import load_plan, record_plan
from recorder.sources.registry import SyntheticSource
from tests.helpers import write_accepted_capture
from twopose.camera.model import Camera, Intrinsics
from twopose.format.entries import GroundTruth, PoseEntry, SessionInfo
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.values.units import Units

TWO_TRIALS = "poses = [{ t = [0.0, 0.0, 0.0] }, { t = [1.1, 0.0, 0.0] }]\n"


def _planned(path: Path, truth: str) -> Path:
    plan = path.with_suffix(".toml")
    trial = f"[[trials]]\n{truth}{TWO_TRIALS}"
    plan.write_text(f'method = "point"\nframes = 2\n[camera]\nfocal = 525.0\n{trial}{trial}')
    record_plan(load_plan(plan), path, SyntheticSource(None, Method.POINT, realtime=False))
    return path


@pytest.fixture(scope="module")
def odd_sessions(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    folder = tmp_path_factory.mktemp("odd")
    return {
        "no_truth": _planned(folder / "no_truth.mcap", ""),
        "absurd_truth": _written(folder / "absurd.mcap", (1, 2), (1e300, 0.0, 1e300)),
        "normal": _planned(folder / "normal.mcap", "ground_truth = [[0.5, 1.5, 11.0]]\n"),
        "repeated_trial": _written(folder / "repeated.mcap", (1, 2, 1), (0.5, 1.5, 11.0)),
    }


def _written(path: Path, trials: tuple[int, ...], truth: tuple[float, float, float]) -> Path:
    """A session as another writer may make it: these trial numbers (1, 2, 1 repeats one),
    and this ground truth (the recorder refuses an absurd one)."""
    cam = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0),
    )
    with (
        SyntheticSource(None, Method.POINT, realtime=False) as src,
        SessionWriter(
            path, SessionInfo(method=Method.POINT, units=Units.IN), [cam], start_ns=0
        ) as w,
    ):
        t = 10
        for trial in trials:
            w.write_ground_truth(GroundTruth(trial=trial, kind="point", points_grid=(truth,)), t)
            for pose, x in ((1, 0.0), (2, 1.1)):
                src.set_pose((x, 0.0, 0.0), (0.0, 0.0, 0.0))
                entry = PoseEntry(trial=trial, pose=pose, camera_id="cam0", t_grid=(x, 0.0, 0.0))
                t = write_accepted_capture(w, entry, [src.read(), src.read()], t + 10)
    return path


@pytest.mark.slow
@pytest.mark.parametrize("kind", ["no_truth", "absurd_truth", "repeated_trial"])
def test_an_odd_session_in_a_batch_keeps_the_report(
    tmp_path: Path, odd_sessions: dict[str, Path], kind: str
) -> None:
    out = tmp_path / "out"
    figures = AnalysisOptions(figures=("png",))  # the static figures drawn, not merely charts
    result = run([odd_sessions["normal"], odd_sessions[kind]], out, options=figures)
    assert result.errors.empty, result.errors
    assert (out / "report.html").is_file()
    for name in ("error_histogram", "error_by_trial", "error_vs_baseline"):
        assert (out / f"{name}.png").stat().st_size > 1000
    report = (out / "report.html").read_text()
    assert "figure not drawn" not in report  # drawn, not merely survived
    summary = pd.read_csv(out / "summary.csv").set_index("session")
    normal = summary.loc[str(odd_sessions["normal"])]
    assert normal["within_1"] == 1.0
    odd = summary.loc[str(odd_sessions[kind])]
    if kind == "no_truth":
        assert np.isnan(odd["rmse"])
        assert np.isnan(odd["within_1"])  # unknown, not "none within 1 in"
    if kind == "absurd_truth":
        # Beyond the bound of a ground-truth point: not compared (no overflowing error, no
        # "0% within 1 in"), and said in the trial's notes; the estimates stay.
        assert np.isnan(odd["rmse"])
        assert np.isnan(odd["within_1"])
        trials = pd.read_csv(out / "trials.csv")
        absurd = trials[trials["session"] == str(odd_sessions[kind])]
        assert (absurd["status"] == "ok").all()
        said = absurd["notes"].str.contains("ground truth x must be from -200 to 200 in")
        assert said.all(), absurd["notes"]


@pytest.mark.parametrize("bad", ["bomb", "empty", "wrong_size"])
def test_one_bad_frame_is_one_rejected_frame(tmp_path: Path, bad: str) -> None:
    """A frame that declares 32000x32000 (634 bytes), an empty one, or one whose size
    differs from the calibration: that frame is rejected with the reason, the session is
    analysed, and no memory is spent on it."""
    import cv2

    from analysis.session.pipeline import analyse_session
    from tests.helpers import jpeg_declaring

    frame = {
        "bomb": jpeg_declaring(32000, 32000),
        "empty": b"",
        "wrong_size": cv2.imencode(".jpg", np.zeros((48, 64, 3), np.uint8))[1].tobytes(),
    }[bad]
    cam = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0),
    )
    path = tmp_path / "s.mcap"
    with (
        SyntheticSource(None, Method.POINT, realtime=False) as src,
        SessionWriter(
            path, SessionInfo(method=Method.POINT, units=Units.IN), [cam], start_ns=0
        ) as w,
    ):
        w.write_ground_truth(GroundTruth(trial=1, kind="point", points_grid=((0.5, 1.5, 11.0),)), 1)
        t = 10
        for pose, x in ((1, 0.0), (2, 1.1)):
            src.set_pose((x, 0.0, 0.0), (0.0, 0.0, 0.0))
            good = [w.encode_image(src.read()), w.encode_image(src.read())]
            entry = PoseEntry(trial=1, pose=pose, camera_id="cam0", t_grid=(x, 0.0, 0.0))
            t = write_accepted_capture(w, entry, [*good, frame] if pose == 2 else good, t + 10)
    result = analyse_session(path)
    assert result.trials["status"].tolist() == ["ok"]
    assert result.trials["err"].iloc[0] < 0.1
    rejected = result.frames[~result.frames["found"]]
    assert len(rejected) == 1
    reason = rejected["reason"].iloc[0]
    assert {"bomb": "over the limit", "empty": "not a readable image", "wrong_size": "640x480"}[
        bad
    ] in reason


@pytest.mark.parametrize("method", ["point", "line", "ground"])
def test_poses_typed_identical_are_degenerate_not_ok(tmp_path: Path, method: str) -> None:
    """Every pose of a trial typed at one place: no method may report ok (ground and line
    trials were ok with 15-20 in of error)."""
    from analysis.session.pipeline import analyse_session

    truth = {"point": "[[0.5, 1.5, 11.0]]", "line": "[[0, 9.625, 8], [2, 9.625, 9]]"}
    truth["ground"] = "[[1.91, 9.625, 8.375]]"
    same = "poses = [{ t = [0.5, 0.0, 0.0] }, { t = [0.5, 0.0, 0.0] }]\n"
    trial = f"[[trials]]\nground_truth = {truth[method]}\n{same}"
    plan = tmp_path / "plan.toml"
    plan.write_text(
        f'method = "{method}"\nframes = 2\nground_height = 9.625\n[camera]\nfocal = 525.0\n'
        + trial * 2
    )
    path = tmp_path / "s.mcap"
    record_plan(load_plan(plan), path, SyntheticSource(None, Method(method), realtime=False))
    trials = analyse_session(path).trials
    assert (trials["status"] != "ok").all(), trials[["status", "reason"]]
    found = trials[trials["status"] == "degenerate"]
    assert len(found) >= 1
    assert found["reason"].str.contains("no baseline").all()


def test_a_session_over_the_time_limit_fails_alone(tmp_path: Path, point_session: Path) -> None:
    from analysis.results import AnalysisOptions

    # The shared small session (the odd sessions' fixture costs 25 s of the quick loop).
    options = AnalysisOptions(session_timeout_s=1e-3)
    result = run([point_session], None, options=options)
    assert len(result.errors) == 1
    assert "stopped after 0.001 s (--session-timeout)" in result.errors["error"].iloc[0]
    assert len(run([point_session], None).sessions) == 1  # the default: no problem


def test_a_fifo_named_mcap_is_refused_not_waited_on(tmp_path: Path) -> None:
    import os

    from typer.testing import CliRunner

    from analysis.cli import app

    fifo = tmp_path / "pipe.mcap"
    os.mkfifo(fifo)
    result = CliRunner().invoke(app, ["info", str(fifo)])
    assert result.exit_code == 3
    assert "is not a regular file" in result.output
    result = CliRunner().invoke(app, ["info", str(tmp_path)])  # in a folder: not a session
    assert "no session files" in result.output


@pytest.mark.slow
def test_ctrl_c_with_two_jobs_exits_130_without_a_worker_traceback(
    tmp_path: Path, odd_sessions: dict[str, Path]
) -> None:
    import os
    import signal
    import subprocess
    import sys
    import time

    from tests.helpers import distinct_copies

    folder = tmp_path / "in"
    # Enough that the batch is still running when Ctrl-C comes (distinct files: copies of
    # one session would be counted once).
    distinct_copies(odd_sessions["normal"], folder, 24)
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    proc = subprocess.Popen(
        [sys.executable, "-m", "analysis", "run", folder, "--out", tmp_path / "o", "--jobs", "2"],
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        text=True,
        env=env,
        start_new_session=True,  # Ctrl-C reaches the whole group, as at a terminal
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )
    time.sleep(3.0)  # the workers are up and analysing
    os.killpg(proc.pid, signal.SIGINT)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode == 130, err
    assert "Traceback" not in err
    assert "interrupted" in err
