"""A run is one transaction (analysis.batch.outputs.OutputFolder): a re-run into an existing
results folder that is interrupted (Ctrl-C, SIGTERM, kill -9, an error) leaves the
previous results byte for byte, no lock file and no stray file; a commit a kill cut short
is finished by the next run; an output folder inside the sessions folder stays ours."""

from __future__ import annotations

import hashlib
import os
import shutil
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest
from typer.testing import CliRunner

from analysis.batch.cache import CACHE_FOLDER
from analysis.batch.outputs import LOCK_NAME, MANIFEST_NAME, STAGING_NAME, OutputFolder
from analysis.cli import app
from tests.helpers import distinct_copies

runner = CliRunner()
SAMPLES = Path(__file__).resolve().parents[2] / "sessions"


def _snapshot(folder: Path) -> dict[str, str]:
    """Every result under ``folder`` and its content's hash: the staging folder apart, and
    the re-run cache's (its entries, keyed by what they hold, may be written again by a
    run that analyses anew; never a result)."""
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and not {STAGING_NAME, CACHE_FOLDER} & set(p.relative_to(folder).parts)
    }


def test_a_failure_inside_the_run_leaves_the_previous_results(tmp_path: Path) -> None:
    out = tmp_path / "out"
    with OutputFolder.prepare(out) as folder:
        folder.write_bytes("a.csv", b"first")
        folder.record(["a.csv"])
    before = _snapshot(out)

    def failing_run() -> None:
        with OutputFolder.prepare(out) as folder:
            folder.write_bytes("a.csv", b"second, half written")
            folder.write_bytes("b.csv", b"new")
            raise RuntimeError("the disk filled up")

    with pytest.raises(RuntimeError):
        failing_run()
    assert _snapshot(out) == before
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST_NAME, "a.csv"]  # no lock file


def test_a_commit_cut_short_is_finished_by_the_next_run(tmp_path: Path) -> None:
    """A kill between the commit's renames: the next run moves the rest in first."""
    out = tmp_path / "out"
    with OutputFolder.prepare(out) as folder:
        folder.write_bytes("old.csv", b"old")
        folder.record(["old.csv"])
    staging = out / STAGING_NAME
    staging.mkdir()
    (staging / "new.csv").write_bytes(b"new")
    (staging / MANIFEST_NAME).write_text('{"files": ["new.csv"]}')
    (staging / ".committing").write_bytes(b"")
    with OutputFolder.prepare(out):
        pass  # nothing recorded: this run leaves what it found, finished
    assert (out / "new.csv").read_bytes() == b"new"
    assert not (out / "old.csv").exists()
    assert not staging.exists()


def test_a_run_never_committing_is_removed_by_the_next(tmp_path: Path) -> None:
    out = tmp_path / "out"
    (out / STAGING_NAME).mkdir(parents=True)
    (out / STAGING_NAME / "results_00_x.mcap").write_bytes(b"half")
    (out / LOCK_NAME).write_bytes(b"")  # an older twopose's lock file
    with OutputFolder.prepare(out) as folder:
        folder.record([])
    assert sorted(p.name for p in out.iterdir()) == [MANIFEST_NAME]


def test_an_output_folder_inside_the_sessions_folder_stays_ours(
    tmp_path: Path, line_session: Path
) -> None:
    """``run S --out S/results`` twice: the second run reads the sessions, not the first
    run's results files, and does not take its own folder for an input (a small simulated
    session: four runs of a 15-trial sample took ~16 s)."""
    sessions = tmp_path / "S"
    sessions.mkdir()
    shutil.copy(line_session, sessions)
    for _ in range(2):
        result = runner.invoke(
            app, ["run", str(sessions), "--out", str(sessions / "results"), "--no-scene"]
        )
        assert result.exit_code == 0, result.output
    result = runner.invoke(app, ["run", str(sessions), "--out", str(sessions / "results")])
    assert result.exit_code == 0, result.output
    result = runner.invoke(app, ["run", str(sessions), "--out", str(sessions / "results")])
    assert result.exit_code == 0, result.output
    assert "skipped 1 results file(s)" in result.output


def _rerun(folder: Path, out: Path) -> subprocess.Popen[str]:
    """The re-run analyses again (``--no-reuse``): one that reuses the first run's analysis
    ends before the signal comes (issue 47)."""
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    command = ["run", str(folder), "--out", str(out), "--jobs", "2", "--no-reuse"]
    return subprocess.Popen(
        [sys.executable, "-m", "analysis", *command],
        stderr=subprocess.PIPE,
        stdout=subprocess.DEVNULL,
        text=True,
        env=env,
        start_new_session=True,  # a signal reaches the whole group, as at a terminal
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )


@pytest.mark.slow
@pytest.mark.parametrize(
    ("sig", "after_s"), [(signal.SIGINT, 3.0), (signal.SIGTERM, 5.0), (signal.SIGKILL, 4.0)]
)
def test_an_interrupted_rerun_leaves_the_previous_results_byte_for_byte(
    tmp_path: Path, sig: signal.Signals, after_s: float
) -> None:
    folder = tmp_path / "in"
    # Enough that the re-run is still running when the signal comes (distinct files:
    # copies of one session would be counted once).
    distinct_copies(SAMPLES / "thesis_method2_ground.mcap", folder, 16)
    out = tmp_path / "r"
    first = runner.invoke(app, ["run", str(folder), "--out", str(out)])
    assert first.exit_code == 0, first.output
    before = _snapshot(out)
    assert len(before) > 20  # a results MCAP per session, the tables and the report
    proc = _rerun(folder, out)
    time.sleep(after_s)
    os.killpg(proc.pid, sig)
    _, err = proc.communicate(timeout=120)
    assert proc.returncode != 0, err
    assert "Traceback" not in err
    assert _snapshot(out) == before  # the previous results, byte for byte
    if sig is not signal.SIGKILL:  # a run that could clean up left nothing behind
        assert not (out / STAGING_NAME).exists()
    assert not (out / LOCK_NAME).exists()
    # The next run goes ahead (a killed run's lock died with it) and cleans up.
    again = runner.invoke(app, ["run", str(folder), "--out", str(out), "--no-scene"])
    assert again.exit_code == 0, again.output
    assert not (out / STAGING_NAME).exists()


def test_a_run_with_nothing_to_analyse_leaves_the_results_as_they_were(
    tmp_path: Path, point_session: Path
) -> None:
    """Issue 56: `run EMPTY_FOLDER --out X` over a complete results folder exited 1 and left
    trials.csv header-only, the results_*.mcap deleted and the cache emptied. A run that
    finds nothing to analyse (no session file; only an earlier run's results file) is not
    a run that replaces them: X is left as it was, cache included, and it says so."""
    import analysis

    out = tmp_path / "out"
    analysis.run([point_session], out)
    every = {str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()}
    assert "results_00_point.mcap" in every
    assert any(name.startswith(CACHE_FOLDER) and name.endswith(".pickle") for name in every)
    empty, results_only = tmp_path / "empty", tmp_path / "earlier"
    empty.mkdir()
    results_only.mkdir()
    shutil.copy(out / "results_00_point.mcap", results_only)
    for given in (empty, results_only):
        result = runner.invoke(app, ["run", str(given), "--out", str(out)])
        assert result.exit_code == 1, result.output
        assert f"nothing written, {out} left as it was" in result.output
        assert "report:" not in result.output
        after = {
            str(p.relative_to(out)): p.read_bytes() for p in sorted(out.rglob("*")) if p.is_file()
        }
        assert after == every
    assert analysis.run([empty], out).written_to is None
