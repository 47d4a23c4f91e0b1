"""procedure: the state machine and the one recording loop, through real session files."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest
from numpy.typing import NDArray

from recorder.procedure.capture import (
    CaptureResult,
    CaptureSettings,
    Shortfall,
    detection_shortfall,
)
from recorder.procedure.driver import (
    Decision,
    Driver,
    LowDetectionError,
    Placement,
    ProcedureError,
    ProcedureRefusedError,
)
from recorder.procedure.machine import TRANSITIONS, Procedure, State
from recorder.procedure.recording import record
from recorder.sources.registry import ImagesSource, VideoSource
from tests.helpers import write_video
from twopose.camera.model import Camera, Intrinsics
from twopose.errors import SessionExistsError
from twopose.format.entries import CaptureDecision, CaptureWindow, Note, PoseEntry, SessionInfo
from twopose.format.reader import SessionReader
from twopose.format.trials import iter_trials
from twopose.format.writer import SessionWriter
from twopose.guidance.advice import Advice
from twopose.methods.specs import Method
from twopose.values.choices import Target
from twopose.values.units import Units

CAM = Camera(
    camera_id="cam0", intrinsics=Intrinsics(width=32, height=24, fx=30.0, fy=30.0, cx=16.0, cy=12.0)
)
INFO = SessionInfo(method=Method.POINT, units=Units.IN)
TWO_FRAMES = CaptureSettings(frames=2)


def _frames(folder: Path, n: int = 60) -> Path:
    folder.mkdir()
    for k in range(n):
        cv2.imwrite(str(folder / f"{k:03d}.png"), np.full((24, 32, 3), k, np.uint8))
    return folder


def test_events_the_state_does_not_allow_are_errors(tmp_path: Path) -> None:
    with SessionWriter(tmp_path / "s.mcap", INFO, [CAM], image_format="png") as w:
        proc = Procedure(w)
        for event in ("accept", "redo", "undo"):
            with pytest.raises(ProcedureError, match=f"cannot {event} while ready"):
                getattr(proc, event)()
        with pytest.raises(ProcedureError, match="cannot type pose while ready"):
            proc.type_pose(PoseEntry(trial=1, pose=1, camera_id="cam0", t_grid=(0, 0, 0)))
        proc.begin_trial(1, 2)
        with pytest.raises(ProcedureError, match="expected trial 1 pose 1"):
            proc.type_pose(PoseEntry(trial=1, pose=2, camera_id="cam0", t_grid=(0, 0, 0)))
        proc.close("test")
        assert proc.state is State.CLOSED
        with pytest.raises(ProcedureError, match="cannot note while closed"):
            proc.note("late")
    assert TRANSITIONS[State.CLOSED] == frozenset()


def test_refusals_leave_the_state_unchanged(tmp_path: Path) -> None:
    with (
        VideoSource(write_video(tmp_path / "v.avi", 3)) as src,
        SessionWriter(tmp_path / "s.mcap", INFO, [CAM], image_format="png") as w,
    ):
        proc = Procedure(w)
        proc.begin_trial(1, 2)
        proc.type_pose(PoseEntry(trial=1, pose=1, camera_id="cam0", t_grid=(0, 0, 0)))
        proc.capture(src, CaptureSettings(frames=2))
        with pytest.raises(ProcedureRefusedError, match="nothing to undo: pose 1 is the first"):
            proc.undo()
        assert (proc.state, proc.pose) == (State.DECIDING, 1)
        proc.accept()
        proc.type_pose(PoseEntry(trial=1, pose=2, camera_id="cam0", t_grid=(1, 0, 0)))
        result = proc.capture(src, CaptureSettings(frames=2))  # one frame left: the video ends
        assert not result.complete
        with pytest.raises(ProcedureRefusedError, match=r"incomplete .* redo it, or quit"):
            proc.accept()
        assert (proc.state, proc.pose) == (State.DECIDING, 2)
        proc.close("source failure")
    with SessionReader(tmp_path / "s.mcap") as r:
        decisions = [e for e in r.iter_entries() if isinstance(e, CaptureDecision)]
    assert [(d.capture, d.decision, d.reason) for d in decisions] == [
        (1, "accept", ""),
        (2, "discard", "source failure"),
    ]


class _Scripted(Driver):
    """Decides from a script; places pose k of trial t at x = k + 10 t."""

    def __init__(self, decisions: list[Decision], trials: int = 1) -> None:
        self.decisions = list(decisions)
        self.trials = trials
        self.placed: list[tuple[int, int]] = []
        self.refusals: list[str] = []

    def next_trial(self, trial: int) -> bool:
        return trial <= self.trials

    def place(self, trial: int, pose: int) -> Placement:
        self.placed.append((trial, pose))
        return Placement(
            entry=PoseEntry(
                trial=trial, pose=pose, camera_id="cam0", t_grid=(pose + 10.0 * trial, 0.0, 0.0)
            )
        )

    def decide(self, trial: int, pose: int, result: CaptureResult) -> Decision:
        return self.decisions.pop(0)

    def refused(self, error: ProcedureRefusedError) -> None:
        self.refusals.append(str(error))

    def note(self, trial: int) -> Note:
        return Note(text=f"note in trial {trial}", trial=trial)


A, R, U, N, Q = Decision.ACCEPT, Decision.REDO, Decision.UNDO, Decision.NOTE, Decision.QUIT


@pytest.mark.parametrize(
    ("decisions", "placed", "used"),
    [
        ([A, A], [(1, 1), (1, 2)], [(1, 11.0), (2, 12.0)]),
        ([R, A, A], [(1, 1), (1, 1), (1, 2)], [(1, 11.0), (2, 12.0)]),
        ([A, U, A, A], [(1, 1), (1, 2), (1, 1), (1, 2)], [(1, 11.0), (2, 12.0)]),
        ([N, A, Q], [(1, 1), (1, 2)], [(1, 11.0)]),  # quit: the last capture is not used
        ([U, A, A], [(1, 1), (1, 2)], [(1, 11.0), (2, 12.0)]),  # undo at pose 1: refused
    ],
)
def test_the_loop_follows_the_drivers_decisions(
    tmp_path: Path,
    decisions: list[Decision],
    placed: list[tuple[int, int]],
    used: list[tuple[int, float]],
) -> None:
    out = tmp_path / "s.mcap"
    driver = _Scripted(decisions)
    summary = record(
        out,
        INFO,
        [CAM],
        ImagesSource(_frames(tmp_path / "f")),
        driver,
        capture=CaptureSettings(frames=2),
    )
    assert driver.placed == placed
    assert not driver.decisions  # every decision was asked for
    assert (summary.n_captures, summary.n_frames) == (len(placed), 2 * len(placed))
    # Each capture counts once, by its final decision (an accepted capture later undone
    # is discarded).
    assert summary.n_accepted + summary.n_discarded == len(placed)
    assert summary.n_accepted == len(used)
    assert len(driver.refusals) == (1 if decisions[0] is U else 0)
    with SessionReader(out) as r:
        entries = list(r.iter_entries())
        (trial,) = iter_trials(r)
    poses = [(e.trial, e.pose) for e in entries if isinstance(e, PoseEntry)]
    windows = [(e.trial, e.pose, e.n_frames) for e in entries if isinstance(e, CaptureWindow)]
    notes = [e.text for e in entries if isinstance(e, Note)]
    assert poses == placed
    assert windows == [(t, p, 2) for t, p in placed]  # nothing recorded is deleted
    assert notes == (["note in trial 1"] if N in decisions else [])
    assert [(p.entry.pose, p.entry.t_grid[0]) for p in trial.poses] == used


def test_an_existing_file_is_refused_before_the_source_opens(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    out.write_bytes(b"keep me")
    with pytest.raises(SessionExistsError, match="never overwrites"):
        record(out, INFO, [CAM], ImagesSource(tmp_path / "missing"), _Scripted([A, A]))
    assert out.read_bytes() == b"keep me"


class _InterruptingSource(ImagesSource):
    """Real frames from a folder; Ctrl-C arrives at read number ``at`` (counting from 1)."""

    def __init__(self, folder: Path, at: int) -> None:
        super().__init__(folder)
        self.at, self.reads = at, 0

    def read(self, timeout_s: float = 2.0) -> NDArray[np.uint8]:
        self.reads += 1
        if self.reads == self.at:
            raise KeyboardInterrupt
        return super().read(timeout_s)


def test_ctrl_c_during_a_capture_closes_a_valid_file_and_discards_it(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    source = _InterruptingSource(_frames(tmp_path / "f"), at=4)  # pose 2, second frame
    summary = record(out, INFO, [CAM], source, _Scripted([A, A]), capture=TWO_FRAMES)
    assert summary.interrupted
    assert "interrupted" in summary.line()
    with SessionReader(out) as r:
        windows = [e for e in r.iter_entries() if isinstance(e, CaptureWindow)]
        decisions = [e for e in r.iter_entries() if isinstance(e, CaptureDecision)]
        (trial,) = iter_trials(r)
    assert [(w.pose, w.status, w.n_frames) for w in windows] == [
        (1, "complete", 2),
        (2, "incomplete", 1),
    ]
    assert "interrupted" in windows[1].reason
    assert [(d.capture, d.decision) for d in decisions] == [(1, "accept"), (2, "discard")]
    assert [p.entry.pose for p in trial.poses] == [1]
    assert "fewer than two" in trial.why_not_measured()


def test_an_accepted_capture_is_synced_to_disk(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """fsync (the real one, counted) after every accept and at close: power loss loses at
    most the capture in progress."""
    import os

    synced: list[int] = []
    real_fsync = os.fsync

    def counting_fsync(fd: int) -> None:
        synced.append(fd)
        real_fsync(fd)

    monkeypatch.setattr(os, "fsync", counting_fsync)
    out = tmp_path / "s.mcap"
    record(
        out,
        INFO,
        [CAM],
        ImagesSource(_frames(tmp_path / "f")),
        _Scripted([A, R, A]),
        capture=CaptureSettings(frames=2),
    )
    assert len(synced) == 2 + 1  # two accepts, then the close


@pytest.mark.slow
def test_a_full_disk_while_recording_is_a_clear_error_and_recoverable(tmp_path: Path) -> None:
    """RLIMIT_FSIZE makes writes fail as on a full disk: the recorder says so, names
    recover, and recover salvages what reached the disk."""
    import os
    import resource
    import signal
    import subprocess
    import sys

    from recorder.recover import recover_session

    def small_disk() -> None:
        signal.signal(signal.SIGXFSZ, signal.SIG_IGN)
        resource.setrlimit(resource.RLIMIT_FSIZE, (400_000, 400_000))

    plan = tmp_path / "plan.toml"
    plan.write_text(
        'method = "point"\nframes = 5\n[camera]\nfocal = 525.0\n'
        + "[[trials]]\nposes = [{ t = [0.0, 0.0, 0.0] }, { t = [1.1, 0.0, 0.0] }]\n" * 6
    )
    out = tmp_path / "s.mcap"
    env = {**os.environ, "PYTHONPATH": str(Path(__file__).resolve().parents[2])}
    proc = subprocess.run(
        [sys.executable, "-m", "recorder", "new", out, "--plan", plan, "--source", "synthetic"],
        capture_output=True,
        text=True,
        env=env,
        preexec_fn=small_disk,
        timeout=300,
    )
    assert proc.returncode == 3, proc.stderr
    assert "Traceback" not in proc.stderr
    assert "the disk is full" in proc.stderr
    assert f"twopose-record recover {out}" in proc.stderr
    report = recover_session(out, tmp_path / "fixed.mcap")
    assert report.complete_captures >= 1


def _dot_frames(folder: Path, with_dot: list[bool]) -> Path:
    """Frames of 64x48 with a black dot (found by the dot detector) where asked."""
    folder.mkdir()
    for k, dot in enumerate(with_dot):
        image = np.full((48, 64, 3), 255, np.uint8)
        if dot:
            cv2.circle(image, (30, 20), 5, (0, 0, 0), -1)
        cv2.imwrite(str(folder / f"{k:03d}.png"), image)
    return folder


@pytest.mark.parametrize(
    ("with_dot", "shortfall"),
    [
        ([True, True, False, False], Shortfall.OK),  # half: enough
        ([True, False, False, False], Shortfall.FEW_FOUND),
        ([False, False, False, False], Shortfall.NONE_FOUND),
    ],
)
def test_accepting_a_capture_that_rarely_found_its_target_needs_the_operator(
    tmp_path: Path, with_dot: list[bool], shortfall: Shortfall
) -> None:
    """Fewer than half the frames found: accept is refused until the operator confirms
    (accept anyway); none found: refused even then, except unattended (a plan records it)."""
    cam = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=64, height=48, fx=50.0, fy=50.0, cx=32.0, cy=24.0),
    )
    folder = _dot_frames(tmp_path / "f", with_dot * 2)
    with (
        ImagesSource(folder) as src,
        SessionWriter(tmp_path / "s.mcap", INFO, [cam], image_format="png") as w,
    ):
        proc = Procedure(w)
        proc.begin_trial(1, 2)
        proc.type_pose(PoseEntry(trial=1, pose=1, camera_id="cam0", t_grid=(0.0, 0.0, 0.0)))
        result = proc.capture(src, CaptureSettings(frames=len(with_dot), target=Target.DOT.spec))
        assert detection_shortfall(result) is shortfall
        if shortfall is Shortfall.OK:
            proc.accept()
        else:
            with pytest.raises(ProcedureRefusedError, match="found in"):
                proc.accept()
            assert (proc.state, proc.pose) == (State.DECIDING, 1)  # unchanged
        if shortfall is Shortfall.FEW_FOUND:
            with pytest.raises(LowDetectionError, match="only 1 of 4 frames"):
                proc.accept()
            proc.accept(anyway=True)
        if shortfall is Shortfall.NONE_FOUND:
            with pytest.raises(ProcedureRefusedError, match="none of the 4 frames"):
                proc.accept(anyway=True)
            proc.accept(unattended=True)  # a plan cannot ask: it records it
        assert (proc.state, proc.pose, proc.n_accepted) == (State.TYPING, 2, 1)
        proc.close("test")


class _Guided(_Scripted):
    """The scripted driver, hearing the guidance: what it was told, in order."""

    def __init__(self, decisions: list[Decision]) -> None:
        super().__init__(decisions)
        self.heard: list[str] = []

    def place(self, trial: int, pose: int) -> Placement:
        self.placed.append((trial, pose))
        x = (0.0, 2.0)[min(pose, 2) - 1]  # the dot in view from both
        return Placement(
            entry=PoseEntry(trial=trial, pose=pose, camera_id="cam0", t_grid=(x, 0, 0))
        )

    def advice(self, trial: int, advice: Advice) -> bool:
        self.heard.append("advice")
        return False

    def advice_withdrawn(self, trial: int) -> None:
        self.heard.append("withdrawn")


def test_an_undo_back_to_no_accepted_pose_withdraws_the_guidance(tmp_path: Path) -> None:
    """Pose 1 accepted (advice), then pose 2's capture undone: pose 1 is retyped and no
    pose is accepted, so the advice it was given is withdrawn, not left standing."""
    from recorder.sources.registry import SyntheticSource
    from twopose.guidance.advice import Guidance, Reach

    driver = _Guided([A, U, A, A])
    source = SyntheticSource(None, Method.POINT, realtime=False)
    guidance = Guidance(reach=Reach.thesis(Units.IN), target95=None, max_poses=2)
    capture = CaptureSettings.live_detection(INFO, frames=1, guidance=guidance)
    thesis = Camera(
        camera_id="cam0",
        intrinsics=Intrinsics(width=640, height=480, fx=525, fy=525, cx=320, cy=240),
    )
    record(tmp_path / "s.mcap", INFO, [thesis], source, driver, capture=capture)
    assert driver.heard[:3] == ["advice", "withdrawn", "advice"]
