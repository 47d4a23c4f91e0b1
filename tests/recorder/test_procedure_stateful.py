"""The procedure against a model, on random sequences of operator events (hypothesis).

Events: type a pose, capture, accept, redo, undo, note, quit, Ctrl-C during a capture, the
camera failing mid-capture, and kill -9. After every step the file is copied as it is on
disk (what a kill -9 would leave), closed by ``recover``, and replayed the way the analysis
replays it: it must hold exactly the (pose, frames) pairs the model says were accepted, and
nothing discarded. Every frame carries its capture's number in its pixels, so a frame in
the wrong capture is caught too.
"""

from __future__ import annotations

import itertools
import shutil
import tempfile
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, settings
from hypothesis import strategies as st
from hypothesis.stateful import (
    RuleBasedStateMachine,
    initialize,
    invariant,
    precondition,
    rule,
    run_state_machine_as_test,
)
from numpy.typing import NDArray

from recorder.procedure.capture import CaptureSettings
from recorder.procedure.driver import ProcedureRefusedError
from recorder.procedure.machine import Procedure, State
from recorder.recover import recover_session
from recorder.sources.registry import FrameSource, SourceInfo
from twopose.camera.model import Camera, Intrinsics
from twopose.errors import SourceError
from twopose.format.entries import GroundTruth, PoseEntry, SessionInfo
from twopose.format.reader import SessionReader
from twopose.format.trials import iter_trials
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.values.units import Units

CAM = Camera(
    camera_id="cam0", intrinsics=Intrinsics(width=8, height=6, fx=10.0, fy=10.0, cx=4.0, cy=3.0)
)
INFO = SessionInfo(method=Method.POINT, units=Units.IN)
FRAMES = 2
# The replayed pairs: (trial, pose) -> (typed x, capture number seen in every frame, frames)
Pairs = dict[tuple[int, int], tuple[float, int, int]]

RUNS = {"sequences": 0, "steps": 0, "kills": 0, "recovered": 0}


class _ScriptedCamera(FrameSource):
    """Tiny frames whose pixels hold the number of the capture they belong to; the next
    capture can be told to fail (camera error) or be interrupted (Ctrl-C) after k frames."""

    def __init__(self) -> None:
        self.capture_number = 0
        self.read_in_capture = 0
        self.fail_after: int | None = None
        self.interrupt_after: int | None = None

    def open(self) -> SourceInfo:
        self.info = SourceInfo(description="scripted", width=8, height=6, fps=30.0)
        return self.info

    def start_capture(self) -> None:
        self.read_in_capture = 0

    def read(self, timeout_s: float = 2.0) -> NDArray[np.uint8]:
        k, self.read_in_capture = self.read_in_capture, self.read_in_capture + 1
        if self.interrupt_after is not None and k >= self.interrupt_after:
            raise KeyboardInterrupt
        if self.fail_after is not None and k >= self.fail_after:
            raise SourceError("camera stopped delivering frames (scripted)")
        return np.full((6, 8, 3), self.capture_number % 256, np.uint8)


def _replay(path: Path) -> Pairs:
    """What the analysis would be handed: per trial and pose, the typed x, the capture
    number written in the frames' pixels, and the number of frames."""
    pairs: Pairs = {}
    with SessionReader(path) as reader:
        for trial in iter_trials(reader):
            for pc in trial.poses:
                if not pc.complete:
                    continue
                marks = {int(f.decode()[0, 0, 0]) for f in pc.frames}
                assert len(marks) == 1, f"frames of several captures in one: {marks}"
                key = (trial.trial, pc.entry.pose)
                pairs[key] = (pc.entry.t_grid[0], marks.pop(), len(pc.frames))
    return pairs


class ProcedureModel(RuleBasedStateMachine):
    """The recorder's procedure (system under test) beside a plain model of it."""

    def __init__(self) -> None:
        super().__init__()
        RUNS["sequences"] += 1
        self.dir = Path(tempfile.mkdtemp(prefix="twopose-stateful-"))
        self.path = self.dir / "s.mcap"
        self.camera = _ScriptedCamera()
        self.camera.open()
        clock = itertools.count(1_000_000_000, 1_000).__next__  # strictly increasing ns
        self.writer = SessionWriter(self.path, INFO, [CAM], image_format="png", clock=clock)
        self.writer.__enter__()
        self.proc = Procedure(self.writer)
        # The model: what was accepted, per trial and pose, and where the operator is.
        self.accepted: Pairs = {}
        self.trial = 0
        self.pose = 0
        self.n_poses = 0
        self.typed: float | None = None  # the typed, not yet captured pose
        self.captured: tuple[float, int, int, bool] | None = None  # x, number, frames, ok
        self.number = 0
        self.state = State.READY
        self.dead = False  # killed: the original file is abandoned
        self.steps = 0
        self.min_steps = 0  # before this many steps, no event ends the recording

    @initialize(min_steps=st.integers(0, 20))
    def lifetime(self, min_steps: int) -> None:
        """How long the recording runs at least: ending events (quit, Ctrl-C, kill -9)
        would otherwise cut most sequences short."""
        self.min_steps = min_steps

    def _may_end(self) -> bool:
        return self.open and self.steps >= self.min_steps

    def teardown(self) -> None:
        if not self.dead and self.writer.is_open:
            self.writer.close()
        shutil.rmtree(self.dir, ignore_errors=True)

    @property
    def open(self) -> bool:
        return self.state is not State.CLOSED and not self.dead

    # -- events
    @precondition(lambda self: self.open and self.state is State.READY)
    @rule(n_poses=st.integers(2, 3))
    def begin_trial(self, n_poses: int) -> None:
        trial = self.trial + 1
        self.proc.begin_trial(
            trial, n_poses, [GroundTruth(trial=trial, kind="point", points_grid=((0.0, 0.0, 9.0),))]
        )
        self.trial, self.pose, self.n_poses, self.state = trial, 1, n_poses, State.TYPING

    @precondition(lambda self: self.open and self.state in (State.TYPING, State.PLACED))
    @rule(x=st.integers(-50, 50))
    def type_pose(self, x: int) -> None:
        bound = self.proc.type_pose(
            PoseEntry(trial=self.trial, pose=self.pose, camera_id="cam0", t_grid=(x / 4, 0.0, 0.0))
        )
        self.number += 1
        assert bound.capture == self.number
        self.typed, self.state = x / 4, State.PLACED

    @precondition(lambda self: self.open and self.state is State.PLACED)
    @rule(fail_after=st.none() | st.integers(0, FRAMES - 1))
    def capture(self, fail_after: int | None) -> None:
        self.camera.capture_number, self.camera.fail_after = self.number, fail_after
        result = self.proc.capture(self.camera, CaptureSettings(frames=FRAMES))
        assert result.complete == (fail_after is None)
        assert self.typed is not None
        n = FRAMES if fail_after is None else fail_after
        self.captured = (self.typed, self.number, n, result.complete)
        self.state = State.DECIDING

    @precondition(lambda self: self.open and self.state is State.DECIDING)
    @rule()
    def accept(self) -> None:
        assert self.captured is not None
        x, number, n, complete = self.captured
        if not complete:
            with pytest.raises(ProcedureRefusedError, match="incomplete"):
                self.proc.accept()
            return
        self.proc.accept()
        self.accepted[(self.trial, self.pose)] = (x, number, n)
        if self.pose == self.n_poses:
            self.state = State.READY
        else:
            self.pose, self.state = self.pose + 1, State.TYPING

    @precondition(lambda self: self.open and self.state is State.DECIDING)
    @rule()
    def redo(self) -> None:
        self.proc.redo()
        self.state = State.TYPING

    @precondition(lambda self: self.open and self.state is State.DECIDING)
    @rule()
    def undo(self) -> None:
        if self.pose == 1:
            with pytest.raises(ProcedureRefusedError, match="nothing to undo"):
                self.proc.undo()
            return
        self.proc.undo()
        del self.accepted[(self.trial, self.pose - 1)]
        self.pose, self.state = self.pose - 1, State.TYPING

    @precondition(lambda self: self.open)
    @rule(text=st.text(max_size=20))
    def note(self, text: str) -> None:
        self.proc.note(text)

    @precondition(lambda self: self._may_end())
    @rule()
    def quit(self) -> None:
        self.proc.close("quit")
        self.writer.close()
        self.state = State.CLOSED

    @precondition(lambda self: self._may_end() and self.state is State.PLACED)
    @rule(after=st.integers(0, FRAMES - 1))
    def interrupt_during_capture(self, after: int) -> None:
        """Ctrl-C in the middle of a capture: what :func:`record` does with it."""
        self.camera.capture_number, self.camera.interrupt_after = self.number, after
        self.camera.fail_after = None
        with pytest.raises(KeyboardInterrupt):
            self.proc.capture(self.camera, CaptureSettings(frames=FRAMES))
        self.camera.interrupt_after = None
        self.proc.close("interrupted (Ctrl-C)")
        self.writer.close()
        self.state = State.CLOSED

    @precondition(lambda self: self._may_end())
    @rule()
    def kill_9(self) -> None:
        """The recorder dies: the file stays as the last flush left it, never closed."""
        RUNS["kills"] += 1
        self.dead = True
        recover_session(self.path, self.dir / "recovered.mcap")

    @precondition(lambda self: not self.open)
    @rule()
    def read_again(self) -> None:
        """After the end, the final file reads the same every time."""
        assert _replay(self._final()) == self.accepted

    # -- the invariant
    def _final(self) -> Path:
        """The file an analyst gets: the closed session, or what recover made of it."""
        return self.dir / "recovered.mcap" if self.dead else self.path

    def _recovered(self) -> Pairs:
        """Copy the file as it is on disk now, close the copy with recover, replay it."""
        copy, fixed = self.dir / "copy.mcap", self.dir / "fixed.mcap"
        copy.unlink(missing_ok=True)
        fixed.unlink(missing_ok=True)
        shutil.copyfile(self.path, copy)
        recover_session(copy, fixed)
        RUNS["recovered"] += 1
        return _replay(fixed)

    @invariant()
    def replay_holds_exactly_the_accepted_pairs(self) -> None:
        RUNS["steps"] += 1
        self.steps += 1
        if self.open:
            assert self._recovered() == self.accepted  # a kill -9 now would give this
        else:
            assert _replay(self._final()) == self.accepted


@pytest.mark.slow
def test_the_procedure_matches_its_model() -> None:
    before = dict(RUNS)
    run_state_machine_as_test(
        ProcedureModel,
        settings=settings(
            max_examples=150,
            stateful_step_count=30,
            deadline=None,
            suppress_health_check=[HealthCheck.too_slow],
        ),
    )
    assert RUNS["sequences"] - before["sequences"] >= 150
    assert RUNS["kills"] > before["kills"]  # the kill -9 event was generated
    assert RUNS["recovered"] - before["recovered"] > 1000
