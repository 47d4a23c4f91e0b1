"""Analysis outputs: a safe --out, re-runs that replace only their own files, results files
among the inputs skipped, and the operator's notes in info, trials.csv and the report."""

from __future__ import annotations

import json
import shutil
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from analysis.batch import run
from analysis.cli import app
from analysis.outputs import MANIFEST_NAME
from recorder.procedure import Procedure
from recorder.sources import SyntheticSource
from twopose.camera import Camera, Intrinsics
from twopose.errors import EXIT_ERROR
from twopose.format.entries import GroundTruth, PoseEntry, SessionInfo
from twopose.format.writer import SessionWriter

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
    assert set(listed) == second - {"mine.txt", MANIFEST_NAME}
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
    cam = Camera("cam0", Intrinsics(640, 480, 525.0, 525.0, 320.0, 240.0))
    truth = GroundTruth(0, "point", ((0.5, 1.5, 11.0),))
    with (
        SyntheticSource(None, "point", realtime=False) as src,
        SessionWriter(path, SessionInfo(method="point", units="in"), [cam]) as w,
    ):
        proc = Procedure(w)
        proc.note("lamp flickered all session")
        for trial in (1, 2):
            proc.begin_trial(trial, 2, [GroundTruth(trial, "point", truth.points_grid)])
            for pose, x in ((1, 0.0), (2, 1.1)):
                proc.type_pose(PoseEntry(trial, pose, "cam0", (x, 0.0, 0.0)))
                proc.capture(src, 2)
                if trial == 2 and pose == 2:
                    proc.note("pose 2 was bumped")
                    proc.note("then re-measured")
                proc.accept()
    return path


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
    assert "lamp flickered all session" in report
    assert "pose 2 was bumped | then re-measured" in report
