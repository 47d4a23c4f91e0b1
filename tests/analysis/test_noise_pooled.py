"""The analysis' noise across a run (issue 54): a trial whose poses disagree flagged and
named in trials.csv, the terminal and the report (a real session, simulated, one typed x
then edited 1 in off); the sessions of one operator pooled in a first pass, each one's
prior in its cache key, so that a re-run equals a --no-reuse run byte for byte and a new
session of the operator makes the others be analysed again."""

from __future__ import annotations

import json
import math
import tomllib
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from analysis.batch.cache import CACHE_FOLDER
from analysis.batch.runner import run
from analysis.cli import app
from analysis.report.terminal import summary_lines
from recorder.simulate.one_camera import simulate_session
from tests.conftest import built_once
from tests.helpers import SMALL_SCENE, distinct_copies, rewrite_session
from twopose.format.entries import GroundTruth, PoseEntry
from twopose.methods.specs import Method
from twopose.sim.scene import load_scene

runner = CliRunner()
REUSED = "analysis: {n} of {m} session(s)' reused from the last run into"


def _mistyped(session: Path, out: Path, trial: int, pose: int, dx: float) -> Path:
    """``session`` with trial ``trial``'s pose ``pose`` typed ``dx`` off in x: every other
    byte of its messages the same (the camera stood where the file first said)."""

    def edit(topic: str, data: bytes) -> bytes:
        if topic != PoseEntry.TOPIC:
            return data
        typed = json.loads(data)
        if (typed["trial"], typed["pose"]) != (trial, pose):
            return data
        typed["translation"][0] += dx
        return json.dumps(typed).encode()

    return rewrite_session(session, out, edit=edit)


@pytest.fixture(scope="module")
def blundered(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small rendered point session, 3 trials of 3 poses, typed right; then trial 2's
    second pose typed 1 in off in x."""

    def build(folder: Path) -> None:
        scene = load_scene(None, **tomllib.loads(SMALL_SCENE))
        clean = folder / "clean.mcap"
        simulate_session(clean, method=Method.POINT, trials=3, frames=2, seed=5, poses=3,
                         pose_noise=0.0625, scene=scene)  # fmt: skip
        _mistyped(clean, folder / "blunder.mcap", 2, 2, 1.0)

    return built_once(tmp_path_factory, "noise-blunder", build) / "blunder.mcap"


def test_a_mistyped_pose_is_flagged_and_said_in_trials_csv_the_terminal_and_the_report(
    blundered: Path, tmp_path: Path
) -> None:
    out = tmp_path / "out"
    done = run([blundered], out)
    trials = done.trials.set_index("trial")
    flagged_row = trials.loc[2].to_dict()
    assert trials["flagged"].tolist() == [False, True, False]
    # three poses: the trial, not the pose; each of them would explain it with its own size
    words = (
        "this trial's poses disagree (typed x of one of them looks about 1 to 5 in off): "
        "check what you typed, or add a fourth pose"
    )
    assert flagged_row["disagreement"] == words
    assert flagged_row["suspect_axis"] == "x"
    assert flagged_row["suspect_pose"] == 0
    assert math.isnan(float(flagged_row["suspect_offset"]))  # no pose named
    assert float(flagged_row["misclosure_p"]) < 0.01
    assert float(flagged_row["noise_widening"]) > float(trials["noise_widening"].iloc[0])
    row = done.summary.iloc[0]
    assert row["n_flagged"] == 1
    assert row["sigma0_dof"] == 6  # the two others
    text = "\n".join(summary_lines(done.trials, done.summary, width=None))
    assert f"flagged: trial 2 (by its misclosure): {words}" in text
    assert "placing sigma 0.0625 in typed;" in text  # the one typed, before the multiplier
    assert "1 trial flagged: kept out of the pool" in text
    report = (out / "report.html").read_text()
    assert words.replace("'", "&#x27;") in report
    assert "a trial both reject on either is flagged" in report  # the rule applied, explained
    assert "the directions a typed pose can move" in report  # the placing directions' test
    written = (out / "trials.csv").read_text()
    assert "suspect_axis" in written.splitlines()[0]
    assert trials["flagged_by"].fillna("").tolist() == ["", "misclosure", ""]


def _truth_moved(session: Path, out: Path, trial: int, dx: float) -> Path:
    """``session`` with trial ``trial``'s ground truth typed ``dx`` off in x."""

    def edit(topic: str, data: bytes) -> bytes:
        if topic != GroundTruth.TOPIC:
            return data
        typed = json.loads(data)
        if typed["trial"] == trial:
            typed["points"][0][0] += dx
        return json.dumps(typed).encode()

    return rewrite_session(session, out, edit=edit)


def test_a_trial_off_its_typed_truth_is_flagged_by_its_truth_and_kept_in_the_errors(
    blundered: Path, tmp_path: Path
) -> None:
    """Trial 3's grid point typed 1 in off in x: its poses agree (no misclosure sees it),
    the session is no longer one target (no other trial sees it); its truth does. It is
    flagged, said so everywhere, kept out of the pool, and kept in every error statistic."""
    moved = _truth_moved(blundered.parent / "clean.mcap", tmp_path / "moved.mcap", 3, 1.0)
    out = tmp_path / "out"
    done = run([moved], out)
    trials = done.trials.set_index("trial")
    assert trials["flagged"].tolist() == [False, False, True]
    assert trials["flagged_by"].fillna("").tolist() == ["", "", "truth"]
    words = str(trials.loc[3, "disagreement"])
    assert words.startswith("this trial's estimate lies 1")
    assert ", mostly in x from the grid point typed as its truth: one of its typed poses, " in words
    assert words.endswith("the grid point, or the detection is off: check what you typed")
    row = done.summary.iloc[0]
    assert row["n_flagged"] == 1
    assert row["sigma0_dof"] == 6  # the two others: kept out of the pool
    errors = trials["err"].to_numpy(dtype=float)
    assert row["rmse"] == pytest.approx(math.sqrt((errors**2).mean()))  # every trial's error
    assert row["max_err"] == pytest.approx(errors.max())
    text = "\n".join(summary_lines(done.trials, done.summary, width=None))
    assert f"flagged: trial 3 (by its truth): {words}" in text
    assert "widened" not in text  # its region is not widened for it
    report = (out / "report.html").read_text()
    assert "trial 3 (by its truth): " + words.replace("'", "&#x27;") in report
    assert "is not widened" in report  # the rule, explained


def test_one_operators_sessions_pool_and_a_rerun_equals_a_no_reuse_run(
    tmp_path: Path, point_session: Path
) -> None:
    folder, out, fresh = tmp_path / "sessions", tmp_path / "out", tmp_path / "fresh"
    distinct_copies(point_session, folder, 3)
    args = ["run", str(folder), "--no-scene"]
    first = runner.invoke(app, [*args, "--out", str(out)])
    assert first.exit_code == 0, first.output
    trials = (out / "trials.csv").read_text()
    assert "2 other sessions of operator twopose simulator (point)" in trials
    # which two, by their ids (check tells priors said alike apart by them)
    summary = pd.read_csv(out / "summary.csv", keep_default_na=False)
    for row in summary.itertuples():
        others = set(summary["session_id"]) - {row.session_id}
        assert set(str(row.prior_sessions).split(";")) == others
    assert len(list((out / CACHE_FOLDER / "sessions").glob("*.noise.pickle"))) == 3
    again = runner.invoke(app, [*args, "--out", str(out)])
    assert REUSED.format(n=3, m=3) in again.output
    no_reuse = runner.invoke(app, [*args, "--out", str(fresh), "--no-reuse"])
    assert no_reuse.exit_code == 0, no_reuse.output
    for name in ("trials.csv", "summary.csv"):
        assert (out / name).read_bytes() == (fresh / name).read_bytes(), name
    # a fourth session of the operator: every other one's prior changed, analysed again
    distinct_copies(point_session, folder, 4)
    fourth = runner.invoke(app, [*args, "--out", str(out)])
    assert fourth.exit_code == 0, fourth.output
    assert "reused" not in fourth.output
    assert "3 other sessions of operator" in (out / "trials.csv").read_text()
