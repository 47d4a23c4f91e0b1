"""A re-run into the same --out reuses each session's analysis (analysis.batch.cache),
and never a stale one: a change to a session's bytes, its identity, an option, the rig file
or the code's version makes it be analysed again."""

from __future__ import annotations

import dataclasses
import json
import pickle
import shutil
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

import analysis.batch.cache as session_cache
from analysis.batch.cache import CACHE_FOLDER, SessionCache, options_digest
from analysis.batch.inputs import SessionIdentity, resolve_inputs
from analysis.batch.runner import run
from analysis.cli import app
from analysis.results import AnalysisOptions, SessionResult, shapes_session_tables
from analysis.rig.calibrate import with_rig
from analysis.session.pipeline import analyse_session
from tests.helpers import distinct_copies
from tests.lab import continue_session
from twopose.detect.detection import GloveParams
from twopose.rig.constants import RigConstants
from twopose.solve.estimate import EstimateOptions
from twopose.uncertainty.noise import NoiseModel

runner = CliRunner()
#: A rig file with a placing sigma (as tests/analysis/test_rig_placing.py's).
PLACING = '[rig]\nunits = "in"\n\n[placing]\nsigma = 0.2\nmeasured_by = "board.mcap"\n'
REUSED = "analysis: {n} of {m} session(s)' reused from the last run into"


def _entries(out: Path) -> list[Path]:
    """The sessions' analyses kept (not their first passes': analysis.batch.noise_pass)."""
    kept = (out / CACHE_FOLDER / "sessions").glob("*.pickle")
    return sorted(p for p in kept if not p.name.endswith(".noise.pickle"))


def _run(folder: Path, out: Path, *extra: str) -> str:
    result = runner.invoke(app, ["run", str(folder), "--out", str(out), "--no-scene", *extra])
    assert result.exit_code == 0, result.output
    return result.output


@pytest.fixture(scope="module")
def analysed(point_session: Path) -> SessionResult:
    return analyse_session(point_session)


def test_each_change_makes_the_session_analysed_again(
    tmp_path: Path, point_session: Path, analysed: SessionResult, monkeypatch: pytest.MonkeyPatch
) -> None:
    folder, out = tmp_path / "sessions", tmp_path / "out"
    folder.mkdir()
    session = folder / "s.mcap"
    shutil.copy(point_session, session)
    calls: list[str] = []

    def analyse() -> SessionResult:  # the session's analysis, as a run would do it
        calls.append("analysed")
        return analysed

    def again(
        options: AnalysisOptions | None, *parts: Path, identity: SessionIdentity | None = None
    ) -> bool:
        """Whether a re-run with ``options`` analyses the session (``parts``) again."""
        cache = SessionCache.of(out, options or AnalysisOptions())
        first, *later = [str(p) for p in parts or (session,)]
        before = len(calls)
        outcome = cache.outcome(first, later, identity, None, analyse)
        assert isinstance(outcome, SessionResult)
        assert outcome.analysis_key
        assert outcome.analysis_reused == (len(calls) == before)
        return len(calls) > before

    assert again(None)
    assert not again(None)
    # its bytes: the same trials in another file (an extra metadata record)
    shutil.copy(distinct_copies(point_session, tmp_path / "copies", 1)[0], session)
    assert again(None)
    assert not again(None)
    # its identity: renamed or copied (its path is what the tables name it by)
    renamed = session.rename(folder / "renamed.mcap")
    assert again(None, renamed)
    assert not again(None, renamed)
    shutil.copy(renamed, folder / "copy.mcap")
    assert again(None, folder / "copy.mcap")
    # ... or a continuation added (the session now has two parts), or another label
    day2 = folder / "renamed_day2.mcap"
    continue_session(renamed, day2, 1)
    assert again(None, renamed, day2)
    assert not again(None, renamed, day2)
    other = dataclasses.replace(SessionIdentity.of_files(renamed, [day2]), label="lab/renamed")
    assert again(None, renamed, day2, identity=other)
    # an option: the sigma0 setting
    no_sigma0 = AnalysisOptions(estimate=EstimateOptions(noise=NoiseModel(test_redundancy=False)))
    assert again(no_sigma0, renamed)
    assert not again(no_sigma0, renamed)
    # the rig file, and then its [placing] alone
    rig = tmp_path / "rig.toml"
    rig.write_text(PLACING)
    inputs = resolve_inputs([renamed])
    with_placing = with_rig(AnalysisOptions(), rig, inputs, print)
    assert again(with_placing, renamed)
    assert not again(with_placing, renamed)
    rig.write_text(PLACING.replace("0.2", "0.3"))
    assert again(with_rig(AnalysisOptions(), rig, inputs, print), renamed)
    # the version
    monkeypatch.setattr("twopose.__version__", "99.0")
    session_cache.code_version.cache_clear()
    try:
        assert again(with_placing, renamed)
    finally:
        session_cache.code_version.cache_clear()


def test_every_field_of_the_options_is_in_the_key() -> None:
    """A change to any field, nested ones included, gives another digest; the fields that
    shape only the run's own outputs (RUN_ONLY) leave the sessions' digest as it was."""
    base = AnalysisOptions()
    shaping = [
        AnalysisOptions(estimate=EstimateOptions(combine="median")),
        AnalysisOptions(estimate=EstimateOptions(min_parallax_deg=1.5)),
        AnalysisOptions(estimate=EstimateOptions(noise=NoiseModel(test_redundancy=False))),
        AnalysisOptions(rig=RigConstants(camera_offset=(0.1, 0.0, 0.0))),
        AnalysisOptions(rig_calibration="loo"),
        AnalysisOptions(glove=GloveParams(min_area_px=201.0)),
    ]
    run_only = [
        AnalysisOptions(session_timeout_s=None),
        AnalysisOptions(include_warned=True),
        AnalysisOptions(figures=("png",)),
    ]
    digests = {options_digest(o) for o in [base, *shaping, *run_only]}
    assert len(digests) == len(shaping) + len(run_only) + 1
    assert options_digest(AnalysisOptions()) == options_digest(base)
    tables = {options_digest(o, tables_only=True) for o in [base, *shaping]}
    assert len(tables) == len(shaping) + 1
    assert {options_digest(o, tables_only=True) for o in run_only} == {
        options_digest(base, tables_only=True)
    }
    marked = {f.name for f in dataclasses.fields(base) if not shapes_session_tables(f.name)}
    assert marked == {"session_timeout_s", "include_warned", "figures"}


# Slow: three runs of one small session (about 4 s).
@pytest.mark.slow
def test_a_rerun_that_changes_only_the_summary_or_the_figures_reuses_the_sessions(
    tmp_path: Path, point_session: Path
) -> None:
    """--include-warned and --figures shape the run's outputs, not a session's tables: the
    re-run reuses the analysis and writes what was asked anew."""
    out = tmp_path / "out"
    first = _run(point_session, out)
    assert "report:" in first, first
    assert "reused" not in first
    assert not list(out.glob("*.png"))
    warned = _run(point_session, out, "--include-warned")
    assert REUSED.format(n=1, m=1) in warned
    assert json.loads((out / "summary.json").read_text())["include_warned"] is True
    drawn = _run(point_session, out, "--figures", "png")
    assert REUSED.format(n=1, m=1) in drawn
    assert json.loads((out / "summary.json").read_text())["include_warned"] is False
    assert len(list(out.glob("*.png"))) >= 3  # the session's figures, drawn for the reused


# Slow: four runs of one small session (about 5 s); the first of a process pays its imports.
@pytest.mark.slow
def test_a_rerun_reuses_the_analysis_and_the_outputs_and_says_so(
    tmp_path: Path, point_session: Path
) -> None:
    out = tmp_path / "out"
    args = ["run", str(point_session), "--out", str(out)]  # with its results.mcap
    first = runner.invoke(app, args)
    assert first.exit_code == 0, first.output
    assert "reused" not in first.output
    trials, report = (out / "trials.csv").read_bytes(), (out / "report.html").read_bytes()
    (out / "report.html").write_text("edited by hand")  # an output changed since: rewritten
    again = runner.invoke(app, args)
    assert REUSED.format(n=1, m=1) in again.output
    assert (out / "trials.csv").read_bytes() == trials
    assert (out / "report.html").read_bytes() == report
    assert [p.name for p in out.glob("results_*.mcap")] == ["results_00_point.mcap"]
    assert len(_entries(out)) == 1
    third = runner.invoke(app, args)  # every output as the last run left it: linked
    assert REUSED.format(n=1, m=1) in third.output
    assert (out / "report.html").read_bytes() == report
    fresh = runner.invoke(app, [*args, "--no-reuse"])
    assert fresh.exit_code == 0, fresh.output
    assert "reused" not in fresh.output
    assert (out / "trials.csv").read_bytes() == trials


# Slow: three runs of one small session (about 3 s).
@pytest.mark.slow
def test_a_corrupt_or_foreign_cache_file_is_ignored_with_a_note(
    tmp_path: Path, point_session: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "out"
    first = run([point_session], out, scene=False)
    (entry,) = _entries(out)
    sweeps = out / CACHE_FOLDER / "sweeps.pickle"
    for bad in (
        entry.read_bytes()[:100],  # cut short
        pickle.dumps({"format": 1, "run": print}),  # names code: refused, never called
    ):
        entry.write_bytes(bad)
        sweeps.write_bytes(bad)
        (out / "report.html").unlink()  # else the last run's outputs are linked, unread
        capsys.readouterr()
        again = run([point_session], out, scene=False)
        assert again.sessions_reused == 0
        said = capsys.readouterr().err
        assert "ignored the unreadable cached analysis" in said
        assert f"ignored the unreadable {sweeps}" in said
        assert "Traceback" not in said
        pd.testing.assert_frame_equal(first.trials, again.trials)


# Slow: two runs of two small sessions (about 4 s).
@pytest.mark.slow
def test_an_entry_moved_under_another_sessions_name_is_refused_in_words(
    tmp_path: Path, point_session: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    """Two entries swapped by hand: each names the session it was kept for, so neither is
    used for the other, and the note says why (not "unreadable": it reads)."""
    sessions = [point_session, *distinct_copies(point_session, tmp_path / "copies", 1)]
    out = tmp_path / "out"
    first = run(sessions, out, scene=False)
    a, b = _entries(out)
    data_a, data_b = a.read_bytes(), b.read_bytes()
    a.write_bytes(data_b)
    b.write_bytes(data_a)
    capsys.readouterr()
    again = run(sessions, out, scene=False)
    said = capsys.readouterr().err
    assert again.sessions_reused == 0
    assert said.count("it was kept for another session, options or version") == 2, said
    assert "unreadable" not in said
    pd.testing.assert_frame_equal(first.trials, again.trials)


# Slow: three runs of one small session and a broken one (about 3 s).
@pytest.mark.slow
def test_a_failed_session_is_not_kept_and_the_cache_is_not_an_input(
    tmp_path: Path, point_session: Path
) -> None:
    folder = tmp_path / "sessions"
    folder.mkdir()
    shutil.copy(point_session, folder / "a.mcap")
    (folder / "broken.mcap").write_bytes(b"\x89MCAP0\r\n" + b"\0" * 64)
    out = folder / "results"  # the results (and the cache) inside the folder read
    first = run([folder], out, scene=False)
    assert len(first.errors) == 1
    assert len(_entries(out)) == 1
    again = run([folder], out, scene=False)
    assert again.sessions_reused == 1
    assert len(again.errors) == 1
    assert len(again.sessions) == 1  # nothing in the cache was taken for a session
    (folder / "broken.mcap").unlink()
    shutil.copy(point_session, folder / "b.mcap")  # a copy of a: counted once, a's label kept
    assert run([folder], out, scene=False).sessions_reused == 1
    assert len(_entries(out)) == 1  # what the last run did not use is gone


# Slow: two runs of a sample session, each in a fresh interpreter (about 6 s).
@pytest.mark.slow
def test_a_rerun_imports_no_estimation_library(tmp_path: Path) -> None:
    """Issue 47: a re-run with nothing changed pays its start-up, not the solvers' or the
    figures' libraries (scipy.stats alone cost a small batch's re-run 0.7 s of its 20%):
    the command line, run twice in fresh interpreters, the second reusing everything."""
    import subprocess
    import sys

    repo = Path(__file__).resolve().parents[2]
    names = ("thesis_method1_point.mcap", "thesis_line.mcap")
    sessions = [str(repo / "sessions" / n) for n in names]
    code = (
        "import sys\n"
        "from analysis.cli import main\n"
        f"sys.argv = ['twopose-analyze', 'run', *{sessions!r}, '--out', {str(tmp_path)!r}]\n"
        "try:\n    main()\nexcept SystemExit:\n    pass\n"
        "heavy = ('scipy.stats', 'scipy.optimize', 'matplotlib')\n"
        "print('IMPORTED', *[m for m in heavy if m in sys.modules])\n"
    )

    def imported() -> tuple[str, list[str]]:
        done = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                              cwd=repo, check=True)  # fmt: skip
        line = [ln for ln in done.stdout.splitlines() if ln.startswith("IMPORTED")][-1]
        return done.stdout + done.stderr, line.split()[1:]

    first, _ = imported()
    assert "report:" in first, first
    assert "reused" not in first
    again, heavy = imported()
    assert REUSED.format(n=2, m=2) in again, again
    assert heavy == [], heavy


def test_every_environment_setting_a_result_depends_on_is_in_the_key(
    tmp_path: Path, point_session: Path, analysed: SessionResult, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 56: each setting of the one declared list (twopose.values.environment) that shapes a
    result, set, makes the session be analysed again; one that shapes none (the traceback
    switch) does not."""
    from twopose.values.environment import ENVIRONMENT

    for setting in ENVIRONMENT:
        monkeypatch.delenv(setting.name, raising=False)
    out = tmp_path / "out"
    calls: list[int] = []

    def analyse() -> SessionResult:
        calls.append(1)
        return analysed

    def again() -> bool:
        before = len(calls)
        SessionCache.of(out, AnalysisOptions()).outcome(str(point_session), [], None, None, analyse)
        return len(calls) > before

    assert again()
    assert not again()
    for setting in ENVIRONMENT:
        monkeypatch.setenv(setting.name, setting.example)
        assert again() == setting.shapes_results, setting.name
        assert not again()
        monkeypatch.delenv(setting.name)
        assert not again()  # the entry kept for the environment as it was, reused


def test_a_limit_in_the_environment_is_applied_to_a_rerun(
    tmp_path: Path, point_session: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """Issue 56: `TWOPOSE_MAX_IMAGE_MPIX=0.1 run` rejects every frame; the re-run without it,
    as the message advises, analysed the frames again (it reused "0/2 ok" from the cache),
    and a lower limit set again is applied, not the cached analysis without it."""
    out = tmp_path / "out"
    monkeypatch.setenv("TWOPOSE_MAX_IMAGE_MPIX", "0.1")
    limited = run([point_session], out, scene=False)
    assert int(limited.summary["n_ok"].sum()) == 0
    monkeypatch.delenv("TWOPOSE_MAX_IMAGE_MPIX")
    free = run([point_session], out, scene=False)
    assert free.sessions_reused == 0
    assert int(free.summary["n_ok"].sum()) == 2
    monkeypatch.setenv("TWOPOSE_MAX_IMAGE_MPIX", "0.1")
    again = run([point_session], out, scene=False)
    assert again.sessions_reused == 0
    assert int(again.summary["n_ok"].sum()) == 0
    pd.testing.assert_frame_equal(again.trials, limited.trials)


def _edit_in_place(path: Path, old: bytes, new: bytes) -> None:
    """``old`` replaced by ``new`` (as long) in ``path``, its size and times kept."""
    import os

    assert len(old) == len(new)
    st = path.stat()
    data = path.read_bytes()
    assert old in data
    path.write_bytes(data.replace(old, new, 1))
    os.utime(path, ns=(st.st_atime_ns, st.st_mtime_ns))
    assert (path.stat().st_size, path.stat().st_mtime_ns) == (st.st_size, st.st_mtime_ns)


def test_an_output_edited_in_place_with_its_size_and_time_kept_is_written_anew(
    tmp_path: Path, point_session: Path
) -> None:
    """Issue 56: `summary.csv` edited in place (rmse 1.34 -> 9.34) with its size and mtime
    kept survived a re-run, which said 1.34 everywhere else; so did a results.mcap. The
    outputs a re-run reuses are checked by their bytes' digest."""
    out = tmp_path / "out"
    run([point_session], out)
    first = {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()}
    summary, scene = out / "summary.csv", next(out.glob("results_*.mcap"))
    _edit_in_place(summary, b",point,in,", b",pOint,in,")
    middle = len(first[scene.name]) // 2
    _edit_in_place(scene, first[scene.name][middle : middle + 8], b"\0" * 8)
    again = run([point_session], out)
    assert again.sessions_reused == 0  # its results.mcap changed: analysed again
    assert summary.read_bytes() == first["summary.csv"]
    assert scene.read_bytes() == first[scene.name]
    assert {p.name: p.read_bytes() for p in out.iterdir() if p.is_file()} == first
