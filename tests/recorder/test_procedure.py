"""procedure: the capture step and the one recording loop."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

from recorder.procedure import CaptureResult, Decision, Driver, Placement, capture_pose, record
from recorder.sources import ImagesSource, VideoSource
from tests.helpers import write_video
from twopose.camera import Camera, Intrinsics
from twopose.format.entries import CaptureWindow, Note, PoseEntry, SessionInfo
from twopose.format.reader import SessionReader
from twopose.format.writer import SessionWriter


def test_a_source_that_stops_mid_capture_leaves_an_incomplete_capture(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    cam = Camera("cam0", Intrinsics(64, 48, 50.0, 50.0, 32.0, 24.0))
    with (
        VideoSource(write_video(tmp_path / "v.avi", 3)) as src,
        SessionWriter(out, SessionInfo(method="point", units="in"), [cam]) as w,
    ):
        result = capture_pose(w, src, PoseEntry(1, 1, "cam0", (0.0, 0.0, 0.0)), 5, target="dot")
    assert not result.complete
    assert result.n_frames == 3
    assert "no more frames" in result.reason
    assert len(result.feedback) == 3
    with SessionReader(out) as r:  # the session stays valid
        (window,) = [e for e in r.iter_entries() if isinstance(e, CaptureWindow)]
    assert (window.status, window.n_frames) == ("incomplete", 3)
    assert "no more frames" in window.reason


class _Scripted(Driver):
    """Decides from a script; places pose k of trial t at x = k + 10 t."""

    def __init__(self, decisions: list[Decision], trials: int = 1) -> None:
        self.decisions = list(decisions)
        self.trials = trials
        self.placed: list[tuple[int, int]] = []

    def next_trial(self, trial: int) -> bool:
        return trial <= self.trials

    def place(self, trial: int, pose: int) -> Placement:
        self.placed.append((trial, pose))
        return Placement(PoseEntry(trial, pose, "cam0", (pose + 10.0 * trial, 0.0, 0.0)))

    def decide(self, trial: int, pose: int, result: CaptureResult) -> Decision:
        return self.decisions.pop(0)

    def note(self, trial: int) -> Note:
        return Note(f"note in trial {trial}", trial)


@pytest.mark.parametrize(
    ("decisions", "placed"),
    [
        ([Decision.ACCEPT, Decision.ACCEPT], [(1, 1), (1, 2)]),
        ([Decision.REDO, Decision.ACCEPT, Decision.ACCEPT], [(1, 1), (1, 1), (1, 2)]),
        (
            [Decision.ACCEPT, Decision.UNDO, Decision.ACCEPT, Decision.ACCEPT],
            [(1, 1), (1, 2), (1, 1), (1, 2)],
        ),
        ([Decision.NOTE, Decision.ACCEPT, Decision.QUIT], [(1, 1), (1, 2)]),
        ([Decision.UNDO, Decision.ACCEPT, Decision.ACCEPT], [(1, 1), (1, 1), (1, 2)]),
    ],
)
def test_the_loop_follows_the_drivers_decisions(
    tmp_path: Path, decisions: list[Decision], placed: list[tuple[int, int]]
) -> None:
    out = tmp_path / "s.mcap"
    folder = tmp_path / "frames"
    folder.mkdir()
    for k in range(40):
        cv2.imwrite(str(folder / f"{k:03d}.png"), np.full((24, 32, 3), k, np.uint8))
    cam = Camera("cam0", Intrinsics(32, 24, 30.0, 30.0, 16.0, 12.0))
    driver = _Scripted(decisions)
    summary = record(
        out, SessionInfo(method="point", units="in"), [cam], ImagesSource(folder), driver, frames=2
    )
    assert driver.placed == placed
    assert not driver.decisions  # every decision was asked for
    assert summary.n_captures == len(placed)
    assert summary.n_frames == 2 * len(placed)
    with SessionReader(out) as r:
        entries = list(r.iter_entries())
    poses = [(e.trial, e.pose) for e in entries if isinstance(e, PoseEntry)]
    windows = [(e.trial, e.pose, e.n_frames) for e in entries if isinstance(e, CaptureWindow)]
    notes = [e.text for e in entries if isinstance(e, Note)]
    assert poses == placed
    assert windows == [(t, p, 2) for t, p in placed]
    assert notes == (["note in trial 1"] if Decision.NOTE in decisions else [])
