"""What happens to session files in a lab, at random (hypothesis): record, continue, fork,
recover, copy, rename, move to another folder, symlink a folder, kill -9 mid-recording,
delete. Whatever the sequence:

- every accepted capture on disk (in a file that can be read) is counted exactly once by
  ``run`` (in this process and with ``--jobs 2``), by ``info`` and by the replay ``rig``
  fits on, a trial being what it is: its session, its part and its number;
- nothing given is said to be missing: a continuation is "not among the inputs" only when
  no readable copy of the part it continues is;
- ``check`` of a run over every folder against a run over any subset of them reports no
  regression.

What is on disk is read with the plain session reader, not with the identity logic the
commands share, so the two are set against each other.
"""

from __future__ import annotations

import itertools
import os
import shutil
import tempfile
from pathlib import Path

import pandas as pd
import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import (
    Bundle,
    RuleBasedStateMachine,
    consumes,
    initialize,
    rule,
    run_state_machine_as_test,
)
from typer.testing import CliRunner

from analysis import run
from analysis.batch.inputs import resolve_inputs
from analysis.cli import app
from analysis.gate.baseline import compare_summaries, load_tolerance
from analysis.session.pipeline import replay_views
from recorder.recover import recover_session
from tests.lab import continue_session, kill_midway, record
from twopose.errors import TwoposeError
from twopose.format.identity import identify_file
from twopose.format.reader import SessionReader
from twopose.format.trials import iter_trials

FOLDERS = ("lab", "laptop", "share")
runner = CliRunner()


def _on_disk(root: Path) -> set[tuple[str, str, int]]:
    """Every trial held by a readable file below ``root`` (links not followed: each real
    file once), as (session id, part id, trial number)."""
    held: set[tuple[str, str, int]] = set()
    for here, _, files in os.walk(root):
        for name in files:
            try:
                with SessionReader(Path(here) / name) as reader:
                    info = reader.info
                    trials = [t.trial for t in iter_trials(reader, with_frames=False)]
            except TwoposeError:
                continue  # interrupted: nothing of it can be counted until it is recovered
            assert info.session_id is not None
            assert info.part_id is not None
            held |= {(info.session_id, info.part_id, t) for t in trials}
    return held


def _counted(trials: pd.DataFrame) -> list[tuple[str, str, int]]:
    return sorted(
        zip(trials["session_id"], trials["part"], trials["trial"].astype(int), strict=True)
    )


class Lab(RuleBasedStateMachine):
    """Three folders of a lab, and the files that come and go in them."""

    files = Bundle("files")
    broken = Bundle("broken")

    def __init__(self) -> None:
        super().__init__()
        self.root = Path(tempfile.mkdtemp(prefix="lab_"))
        self.names = itertools.count()
        for folder in FOLDERS:
            (self.root / folder).mkdir()

    def _new(self, folder: str, stem: str = "visit") -> Path:
        return self.root / folder / f"{stem}_{next(self.names)}.mcap"

    @initialize(target=files)
    def first(self) -> Path:
        path = self._new("lab")
        record(path, 2)
        return path

    @rule(target=files, folder=st.sampled_from(FOLDERS), n=st.integers(1, 2))
    def record_one(self, folder: str, n: int) -> Path:
        path = self._new(folder)
        record(path, n)
        return path

    @rule(target=files, of=files, folder=st.sampled_from(FOLDERS), n=st.integers(1, 2))
    def continue_one(self, of: Path, folder: str, n: int) -> Path:
        """A continuation; continuing one file twice is a fork (two laptops)."""
        path = self._new(folder, of.stem.split("_")[0] + "d")
        if of.exists():
            continue_session(of, path, n)
        else:
            record(path, n)  # the file was moved or deleted meanwhile: a new session
        return path

    @rule(target=files, of=files, folder=st.sampled_from(FOLDERS), same_name=st.booleans())
    def copy(self, of: Path, folder: str, same_name: bool) -> Path:
        path = self.root / folder / of.name if same_name else self._new(folder, "backup")
        if of.exists() and not path.exists():
            shutil.copy(of, path)
            return path
        return of

    @rule(target=files, of=consumes(files), folder=st.sampled_from(FOLDERS))
    def move(self, of: Path, folder: str) -> Path:
        path = self._new(folder, "renamed")
        if of.exists():
            of.rename(path)
            return path
        return of

    @rule(of=consumes(files))
    def delete(self, of: Path) -> None:
        of.unlink(missing_ok=True)

    @rule(target=broken, folder=st.sampled_from(FOLDERS), of=files, keep=st.floats(0.3, 0.9))
    def kill_recording(self, folder: str, of: Path, keep: float) -> Path:
        """kill -9 while recording a new session or a continuation."""
        path = self._new(folder, "killed")
        if of.exists() and keep > 0.6:
            continue_session(of, path, 2)
        else:
            record(path, 2)
        kill_midway(path, keep)
        return path

    @rule(target=files, of=consumes(broken))
    def recover(self, of: Path) -> Path:
        path = of.with_name(of.stem + "_fixed.mcap")
        if of.exists() and not path.exists():
            try:
                recover_session(of, path)
            except TwoposeError:  # nothing of it survived: it stays as it is
                return of
        return path

    @rule(into=st.sampled_from(FOLDERS), to=st.sampled_from(FOLDERS))
    def link_folder(self, into: str, to: str) -> None:
        """A folder linked into another (lab/linked -> ../share); a link to itself or an
        ancestor is a cycle the search must end."""
        link = self.root / into / f"link_{next(self.names)}"
        link.symlink_to(Path("..") / to)

    def teardown(self) -> None:
        try:
            self._check()
        finally:
            shutil.rmtree(self.root, ignore_errors=True)

    def _check(self) -> None:
        held = _on_disk(self.root)
        folders = [self.root / f for f in FOLDERS]
        result = run(folders)
        counted = _counted(result.trials)
        assert counted == sorted(held), "run"
        assert len(set(counted)) == len(counted), "a trial counted twice"
        assert _counted(run(folders, jobs=2).trials) == counted, "run --jobs 2"
        inputs = resolve_inputs(folders)
        replayed = sum(
            len(replay_views(head, continuations=inputs.continuations.get(head, ())).trial_ids)
            for head in inputs.files
            if all(p.file.readable for s in inputs.strands if s.head == head for p in s.parts)
        )
        assert replayed == len(held), "the rig's replay"
        info = runner.invoke(app, ["info", *map(str, folders)], env={"COLUMNS": "200"})
        assert "Traceback" not in info.output
        readable_parts = {p for _, p, _ in held}
        for note in inputs.notes():
            if "is not among the inputs" in note:
                said = identify_file(note.split(":", 1)[0]).info
                assert said is not None
                assert said.continues_part not in readable_parts, note
        self._check_gate(folders, result)

    def _check_gate(self, folders: list[Path], everything: object) -> None:
        """Any subset of the folders as the baseline: no regression."""
        for k in range(1, len(folders)):
            subset = run(folders[:k])
            outcome = compare_summaries(
                everything.summary,  # type: ignore[attr-defined]
                subset.summary,
                load_tolerance(None),
                trials=(everything.trials, subset.trials),  # type: ignore[attr-defined]
            )
            assert not outcome.regressed, outcome.worse()


# A random exploration (12 new sequences of file operations, each step running run twice,
# info and check: ~20 s idle): make test-all runs it; the quick loop keeps the identity
# rules' fixed cases (tests/analysis/test_session_identity.py, test_input_set.py).
@pytest.mark.slow
def test_every_capture_in_a_lab_is_counted_once_whatever_happens_to_its_files() -> None:
    run_state_machine_as_test(
        Lab,
        settings=settings(
            max_examples=12,
            stateful_step_count=10,
            deadline=None,
            suppress_health_check=[HealthCheck.too_slow, HealthCheck.filter_too_much],
        ),
    )
