"""Analysis outputs: a safe --out, re-runs that replace only their own files, results files
among the inputs skipped, and the operator's notes in info, trials.csv and the report."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from analysis.batch.cache import CACHE_FOLDER
from analysis.batch.outputs import LOCK_NAME, MANIFEST_NAME
from analysis.batch.runner import run
from analysis.cli import app
from recorder.procedure.capture import CaptureSettings
from recorder.procedure.machine import Procedure
from recorder.sources.registry import SyntheticSource
from twopose.camera.model import Camera, Intrinsics
from twopose.errors import EXIT_ERROR
from twopose.format.entries import GroundTruth, PoseEntry, SessionInfo
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.values.units import Units

runner = CliRunner()


def test_a_rerun_replaces_its_own_outputs_and_nothing_else(
    tmp_path: Path, point_session: Path, line_session: Path
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    (out / "mine.txt").write_text("the analyst's own file")
    run([point_session, line_session], out, scene=True)
    first = {p.name for p in out.iterdir()}
    assert {"results_00_point.mcap", "results_01_line.mcap", "trials.csv"} <= first
    run([line_session], out, scene=True)  # one session now: numbering shifts
    second = {p.name for p in out.iterdir()}
    assert "results_01_line.mcap" not in second  # the stale file is gone
    assert "results_00_point.mcap" not in second
    assert "results_00_line.mcap" in second
    assert not any(n.startswith("scatter_01") for n in second)
    assert (out / "mine.txt").read_text() == "the analyst's own file"
    listed = json.loads((out / MANIFEST_NAME).read_text())["files"]
    assert set(listed) == second - {"mine.txt", MANIFEST_NAME, LOCK_NAME, CACHE_FOLDER}
    assert set(pd.read_csv(out / "trials.csv")["session"]) == {str(line_session)}


def test_a_tampered_output_list_cannot_delete_outside_the_folder(
    tmp_path: Path, point_session: Path
) -> None:
    out = tmp_path / "out"
    out.mkdir()
    victim = tmp_path / "precious.txt"
    victim.write_text("keep")
    (out / MANIFEST_NAME).write_text(json.dumps({"files": ["../precious.txt", "/etc/passwd"]}))
    run([point_session], out, scene=False)
    assert victim.read_text() == "keep"


@pytest.mark.parametrize("where", ["a_file", "under_a_file"])
def test_a_bad_out_is_a_clear_error(tmp_path: Path, point_session: Path, where: str) -> None:
    blocker = tmp_path / "taken"
    blocker.write_text("x")
    out = blocker if where == "a_file" else blocker / "results"
    result = runner.invoke(app, ["run", str(point_session), "--out", str(out)])
    assert result.exit_code == EXIT_ERROR, result.output
    assert "Traceback" not in result.output
    assert ("is a file" if where == "a_file" else "cannot create the output folder") in (
        result.output
    )
    assert blocker.read_text() == "x"


def test_results_files_among_the_inputs_are_skipped_not_failed(
    tmp_path: Path, point_session: Path
) -> None:
    folder = tmp_path / "data"
    folder.mkdir()
    shutil.copy(point_session, folder / "point.mcap")
    first = runner.invoke(app, ["run", str(folder), "--out", str(folder / "results")])
    assert first.exit_code == 0, first.output
    assert (folder / "results" / "results_00_point.mcap").is_file()
    again = runner.invoke(app, ["run", str(folder), "--out", str(tmp_path / "again")])
    assert again.exit_code == 0, again.output
    assert "skipped 1 results file(s)" in again.output
    assert "failed" not in again.output
    info = runner.invoke(app, ["info", str(folder)], env={"COLUMNS": "200"})
    assert info.exit_code == 0, info.output
    assert "skipped 1 results file(s)" in info.output
    assert "1 session(s)" in info.output


def _noted_session(path: Path) -> Path:
    """Two trials through the real procedure, with a session note and trial notes."""
    cam = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=640, height=480, fx=525.0, fy=525.0, cx=320.0, cy=240.0),
    )
    truth = GroundTruth(trial=0, kind="point", points_grid=((0.5, 1.5, 11.0),))
    with (
        SyntheticSource(None, Method.POINT, realtime=False) as src,
        SessionWriter(path, SessionInfo(method=Method.POINT, units=Units.IN), [cam]) as w,
    ):
        proc = Procedure(w)
        proc.note("lamp flickered all session")
        for trial in (1, 2):
            proc.begin_trial(
                trial, 2, [GroundTruth(trial=trial, kind="point", points_grid=truth.points_grid)]
            )
            for pose, x in ((1, 0.0), (2, 1.1)):
                proc.type_pose(
                    PoseEntry(trial=trial, pose=pose, camera_id="cam0", t_grid=(x, 0.0, 0.0))
                )
                proc.capture(src, CaptureSettings(frames=2))
                if trial == 2 and pose == 2:
                    proc.note("pose 2 was bumped")
                    proc.note("then re-measured")
                proc.accept()
    return path


@pytest.mark.slow
def test_notes_reach_info_trials_csv_and_the_report(tmp_path: Path) -> None:
    session = _noted_session(tmp_path / "noted.mcap")
    info = runner.invoke(app, ["info", str(session)], env={"COLUMNS": "200"})
    assert info.exit_code == 0, info.output
    assert "session: lamp flickered all session" in info.output
    assert "trial 2: pose 2 was bumped" in info.output
    out = tmp_path / "out"
    result = runner.invoke(app, ["run", str(session), "--out", str(out), "--no-scene"])
    assert result.exit_code == 0, result.output
    trials = pd.read_csv(out / "trials.csv", keep_default_na=False)
    assert list(trials["notes"]) == ["", "pose 2 was bumped | then re-measured"]
    assert list(trials["status"]) == ["ok", "ok"]
    report = (out / "report.html").read_text()
    assert "<li>session: lamp flickered all session</li>" in report  # the notes list
    assert "pose 2 was bumped | then re-measured" in report


def test_a_symlink_in_out_is_replaced_never_written_through(
    tmp_path: Path, point_session: Path
) -> None:
    outside = tmp_path / "outside.txt"
    outside.write_text("not yours to overwrite")
    out = tmp_path / "out"
    out.mkdir()
    (out / "trials.csv").symlink_to(outside)
    (out / "report.html").symlink_to(outside)
    run([point_session], out, scene=False)
    assert outside.read_text() == "not yours to overwrite"
    assert not (out / "trials.csv").is_symlink()
    assert (out / "trials.csv").read_text().startswith("session,")


def test_a_second_run_into_the_same_out_is_refused_while_one_writes(
    tmp_path: Path, point_session: Path
) -> None:
    from analysis.batch.outputs import OutputFolder

    out = tmp_path / "out"
    with OutputFolder.prepare(out):  # a run in progress holds the folder
        result = runner.invoke(app, ["run", str(point_session), "--out", str(out)])
        assert result.exit_code == EXIT_ERROR
        assert "another twopose-analyze run is writing into" in result.output
    result = runner.invoke(app, ["run", str(point_session), "--out", str(out), "--no-scene"])
    assert result.exit_code == 0, result.output  # released: the next run goes ahead


def test_a_full_disk_is_a_clear_error_and_leaves_no_half_written_file(
    tmp_path: Path, point_session: Path
) -> None:
    """The file-size limit (RLIMIT_FSIZE) makes writes fail like a full disk (EFBIG)."""
    import os
    import resource
    import signal
    import subprocess
    import sys

    def small_disk() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)  # fail the write, not the process
        resource.setrlimit(resource.RLIMIT_FSIZE, (60_000, 60_000))

    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    proc = subprocess.run(
        [sys.executable, "-m", "analysis", "run", str(point_session), "--out", str(out)],
        capture_output=True,
        text=True,
        env=env,
        preexec_fn=small_disk,
        timeout=300,
    )
    assert proc.returncode == EXIT_ERROR, proc.stderr
    assert "Traceback" not in proc.stderr
    assert "the disk is full" in proc.stderr
    assert not list(out.glob("*.partial"))
    assert not list(out.glob(".*.partial"))
    assert all(p.stat().st_size > 0 for p in out.iterdir() if p.is_file() and p.suffix == ".csv")


@pytest.mark.slow  # a full run per name (~6 s each): make test-all and CI run it
@pytest.mark.parametrize("name", ["na\udcefve.mcap", "s" * 235 + ".mcap"])
def test_odd_session_file_names_are_analysed(
    tmp_path: Path, point_session: Path, name: str
) -> None:
    """A name that is not UTF-8, and one of 239 characters."""
    import os
    import subprocess
    import sys

    session = tmp_path / name
    shutil.copy(point_session, session)
    out = tmp_path / "out"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    proc = subprocess.run(
        [sys.executable, "-m", "analysis", "run", str(tmp_path), "--out", str(out)],
        capture_output=True,
        env=env,
        timeout=300,
    )
    assert proc.returncode == 0, proc.stderr.decode(errors="replace")
    assert b"Traceback" not in proc.stderr
    assert len(pd.read_csv(out / "trials.csv")) == 2
    assert all(len(p.name.encode()) < 255 for p in out.iterdir())
