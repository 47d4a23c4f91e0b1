"""``new --continue`` (issue 36): a session recorded on after a file ends, normally or after
a crash and ``recover``, is one session to the analysis: its id, its setup, its trials
numbered after the first part's, nothing counted twice, in any order of the inputs."""

from __future__ import annotations

import dataclasses
import os
import signal
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import pandas as pd
import pytest
from typer.testing import CliRunner

from analysis.batch.inputs import resolve_inputs
from analysis.batch.runner import run
from analysis.cli import app as analyze
from recorder.cli.app import app as record
from recorder.setup.continuation import read_continued
from tests.helpers import SMALL_SCENE
from twopose.format.identity import identify_file, resolve_session_files
from twopose.format.reader import SessionReader

runner = CliRunner()
PLAN = """method = "ground"
units = "in"
frames = 2
ground_height = 9.625
operator = "Ada"

[camera]
focal = 525.0
principal = [320.0, 240.0]
"""
TRIAL = """
[[trials]]
ground_truth = [[1.91, 9.625, 8.375]]
poses = [{{ t = [{x}, 0.0, 0.0] }}, {{ t = [{x2}, 0.0, 0.0] }}]
"""


def _plan(tmp: Path, name: str, trials: int) -> Path:
    path = tmp / name
    text = PLAN + "".join(TRIAL.format(x=k * 0.5, x2=k * 0.5 + 1.5) for k in range(trials))
    path.write_text(text)
    return path


def _new(*args: str, source: str = "synthetic") -> None:
    result = runner.invoke(record, ["new", *args, "--source", source])
    assert result.exit_code == 0, result.output


def _small(plan: Path) -> str:
    """The plan's camera made :data:`SMALL_SCENE`'s (a pose renders in ~70 ms, not ~500),
    and the ``--source`` that records with it."""
    scene = plan.with_name("scene.toml")
    scene.write_text(SMALL_SCENE)
    small = "focal = 262.5\nprincipal = [160.0, 120.0]\nwidth = 320\nheight = 240\n"
    plan.write_text(plan.read_text().replace("focal = 525.0\nprincipal = [320.0, 240.0]\n", small))
    return f"synthetic:{scene}"


def _trials(*paths: Path, out: Path) -> pd.DataFrame:
    result = runner.invoke(analyze, ["run", *map(str, paths), "--out", str(out), "--no-scene"])
    assert result.exit_code == 0, result.output
    return pd.read_csv(out / "trials.csv")


def test_two_trials_continued_with_two_more_are_one_session_of_four(tmp_path: Path) -> None:
    first, later = tmp_path / "S.mcap", tmp_path / "S2.mcap"
    plans = tmp_path / "plans"
    plans.mkdir()
    plan_a, plan_b = _plan(plans, "a.toml", 2), _plan(plans, "b.toml", 2)
    source = _small(plan_a)
    _small(plan_b)
    _new(str(first), "--plan", str(plan_a), source=source)
    _new(str(later), "--plan", str(plan_b), "--continue", str(first), source=source)
    with SessionReader(first) as a, SessionReader(later) as b:
        assert b.info.session_id == a.info.session_id
        assert b.info.continues_after_trial == 2
        assert b.info.continues_file == "S.mcap"
        assert b.info.method == a.info.method
        assert b.cameras == a.cameras
    # One session with trials 1-4, the folder found or the files named, in either order
    # (the command line once, writing its tables; the library's call, writing nothing, twice).
    for trials in (
        _trials(tmp_path, out=tmp_path / "out"),
        run([later, first], None).trials,
        run([first, later], None).trials,
    ):
        assert list(trials["trial"]) == [1, 2, 3, 4]
        assert set(trials["session"]) == {str(first)}
    info = runner.invoke(analyze, ["info", str(later), str(first)], env={"COLUMNS": "200"})
    assert info.exit_code == 0, info.output
    assert "1 session(s), 1 continued in a later file" in info.output
    found = resolve_inputs([str(later), str(first)])
    assert found.files == [str(first)]
    assert found.continuations == {str(first): (str(later),)}
    assert any("one session with" in n for n in found.notes())
    # Alone, a continuation is a session of its own, said.
    alone = run([str(later)], None)
    assert list(alone.trials["trial"]) == [3, 4]
    assert any("is not among the inputs: analysed alone" in n for n in alone.input_notes)


def test_a_continuation_keeps_the_setup_and_refuses_another(tmp_path: Path) -> None:
    first = tmp_path / "S.mcap"
    _new(str(first), "--plan", str(_plan(tmp_path, "a.toml", 1)))
    result = runner.invoke(
        record, ["new", str(tmp_path / "x.mcap"), "--continue", str(first), "--units", "cm",
                 "--source", "synthetic"],
    )  # fmt: skip
    assert result.exit_code != 0
    assert "--units: a continuation keeps the setup of" in result.output
    other = _plan(tmp_path, "cm.toml", 1)
    other.write_text(other.read_text().replace('units = "in"', 'units = "cm"'))
    result = runner.invoke(
        record, ["new", str(tmp_path / "y.mcap"), "--plan", str(other), "--continue", str(first),
                 "--source", "synthetic"],
    )  # fmt: skip
    assert result.exit_code != 0
    assert "a continuation keeps the session's setup" in result.output
    assert not (tmp_path / "y.mcap").exists()


@pytest.mark.slow
def test_killed_during_trial_3_recovered_and_continued(tmp_path: Path) -> None:
    """kill -9 during trial 3, recover, continue: trials 1-2 kept, the continuation's
    numbered after everything the salvaged file holds, nothing counted twice."""
    crashed, fixed, later = tmp_path / "S.mcap", tmp_path / "FIXED.mcap", tmp_path / "S2.mcap"
    plan = _plan(tmp_path, "four.toml", 4)
    recorder = Path(sys.executable).parent / "twopose-record"
    process = subprocess.Popen(
        [str(recorder), "new", str(crashed), "--plan", str(plan), "--source", "synthetic"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    assert process.stdout is not None
    for line in process.stdout:
        if line.startswith("trial 3 pose 1"):  # trial 3 under way: its first pose captured
            os.kill(process.pid, signal.SIGKILL)
            break
    process.wait(timeout=60)
    assert process.returncode == -signal.SIGKILL
    result = runner.invoke(record, ["recover", str(crashed), "-o", str(fixed)])
    assert result.exit_code == 0, result.output
    _new(str(later), "--plan", str(_plan(tmp_path, "two.toml", 2)), "--continue", str(fixed))
    with SessionReader(later) as reader:
        after = reader.info.continues_after_trial
    assert after is not None
    assert after >= 2
    trials = _trials(fixed, later, out=tmp_path / "out")
    numbers = list(trials["trial"])
    assert numbers[:2] == [1, 2]
    assert numbers[-2:] == [after + 1, after + 2]
    assert len(numbers) == len(set(numbers))  # nothing counted twice
    assert (trials[trials["trial"].isin([1, 2, after + 1, after + 2])]["status"] == "ok").all()


def test_an_interrupted_file_is_refused_with_the_recover_command(tmp_path: Path) -> None:
    first = tmp_path / "S.mcap"
    _new(str(first), "--plan", str(_plan(tmp_path, "a.toml", 1)))
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(first.read_bytes()[:20_000])  # what a power cut leaves
    result = runner.invoke(
        record, ["new", str(tmp_path / "x.mcap"), "--continue", str(cut), "--source", "synthetic"]
    )
    assert result.exit_code == 3
    assert f"twopose-record recover {cut} -o FIXED.mcap" in result.output
    assert "then continue from that: --continue FIXED.mcap" in result.output
    assert "Traceback" not in result.output
    assert not (tmp_path / "x.mcap").exists()


def test_guidance_options_beside_a_plan_are_refused_not_ignored(tmp_path: Path) -> None:
    plan = _plan(tmp_path, "a.toml", 1)
    result = runner.invoke(
        record, ["new", str(tmp_path / "x.mcap"), "--plan", str(plan), "--target-precision",
                 "0.5", "--source", "synthetic"],
    )  # fmt: skip
    assert result.exit_code == 3
    assert "--target-precision: a plan sets its guidance in its [guidance] table" in result.output
    assert not (tmp_path / "x.mcap").exists()


SECOND_WARNING = (
    "S.mcap is already continued by S_laptop1.MCAP (after trial 1): this file starts branch "
    "B of the session; the analysis keeps each branch's trials apart"
)


@dataclass(frozen=True)
class Forked:
    session: Path
    first: Path  # the first continuation (S_laptop1.MCAP)
    second: Path  # the second, beside the first (S_laptop2.mcap)
    said: tuple[str, str]  # what each continuation's `new` printed


@pytest.fixture(scope="module")
def forked(tmp_path_factory: pytest.TempPathFactory) -> Forked:
    setup = tmp_path_factory.mktemp("setup")
    plan = _plan(setup, "one.toml", 1)
    source = _small(plan)
    folder = tmp_path_factory.mktemp("sessions")
    (folder / "junk.mcap").write_bytes(b"not a session")  # passed over quietly
    paths = folder / "S.mcap", folder / "S_laptop1.MCAP", folder / "S_laptop2.mcap"
    said: list[str] = []
    for k, path in enumerate(paths):
        more = ["--continue", str(paths[0])] if k else []
        args = ["new", str(path), "--plan", str(plan), *more, "--source", source]
        result = runner.invoke(record, args)
        assert result.exit_code == 0, result.output
        said.append(result.output)
    return Forked(session=paths[0], first=paths[1], second=paths[2], said=(said[1], said[2]))


def test_every_recording_is_a_fresh_part_and_a_second_continuation_a_branch(
    forked: Forked,
) -> None:
    """Two laptops continue one file: the first continuation is the part's only one (no
    warning, no branch), the second is warned, once, and records branch B; each file is
    a part of its own, each continuation naming the part it continues as the analysis
    does."""
    s = identify_file(forked.session)
    infos = [identify_file(p).info for p in (forked.session, forked.first, forked.second)]
    assert all(i is not None for i in infos)
    session, first, second = (i for i in infos if i is not None)
    assert session.part_id is not None
    assert s.part_id == session.part_id
    parts = {session.part_id, first.part_id, second.part_id}
    assert None not in parts
    assert len(parts) == 3  # fresh, distinct
    for info in (first, second):
        assert info.session_id == session.session_id
        assert info.continues_part == s.part_id
        assert info.continues_sha256 == s.digest
    assert first.continues_branch == ""
    assert "already continued" not in forked.said[0]
    assert second.continues_branch == "B"
    assert forked.said[1].startswith(f"warning: {SECOND_WARNING}\n")  # at the start, once
    assert forked.said[1].count("already continued") == 1
    assert "junk.mcap" not in forked.said[1]
    # The analysis' identity agrees: S forks, the second laptop's part is branch B.
    resolved = resolve_session_files(
        [identify_file(p) for p in (forked.session, forked.first, forked.second)]
    )
    assert len(resolved.forks) == 1
    branches = {p: b for strand in resolved.strands for p, b in strand.branches.items()}
    assert branches[str(forked.second)] == "B"


@pytest.mark.parametrize("refused", ["source", "plan"])
def test_a_refused_continuation_of_a_continued_part_announces_no_branch(
    forked: Forked, tmp_path: Path, refused: str
) -> None:
    """Before: every refused ``new --continue`` of a part another file continues first
    said "this file starts branch C of the session", then refused: no branch was started."""
    out = tmp_path / "C.mcap"
    args = ["new", str(out), "--continue", str(forked.session)]
    if refused == "source":
        args += ["--source", "pair:synthetic,synthetic"]  # two cameras for a one-camera part
    else:
        args += ["--source", "synthetic"]
        plan = _plan(tmp_path, "mm.toml", 1)  # the plan in mm, the session in inches
        plan.write_text(plan.read_text().replace('units = "in"', 'units = "mm"'))
        args += ["--plan", str(plan)]
    result = runner.invoke(record, args)
    assert result.exit_code != 0
    assert "Traceback" not in result.output
    assert "already continued" not in result.output
    assert not out.exists()


def test_a_branch_takes_the_next_free_letter_after_the_continued_part(forked: Forked) -> None:
    """The third continuation of a part is C; a second continuation of a part on branch B
    is BB (no file rendered: the continued session read once)."""
    continued = read_continued(forked.session)
    first = identify_file(forked.first)
    assert continued.part_id == identify_file(forked.session).part_id
    assert {Path(f.path).name for f in continued.continued_by} == {
        "S_laptop1.MCAP",
        "S_laptop2.mcap",
    }
    assert continued.branch == "C"
    assert continued.info_for().continues_branch == "C"
    assert first.info is not None
    on_b = dataclasses.replace(
        continued,
        info=dataclasses.replace(continued.info, continues_branch="B"),
        continued_by=(first,),
    )
    assert on_b.branch == "BB"
    assert on_b.fork_warning is not None
    assert "starts branch BB of the session" in on_b.fork_warning
    alone = dataclasses.replace(continued, continued_by=())
    assert alone.branch == ""
    assert alone.fork_warning is None
    fresh = {alone.info_for().part_id for _ in range(2)}
    assert len(fresh) == 2
    assert continued.part_id not in fresh
