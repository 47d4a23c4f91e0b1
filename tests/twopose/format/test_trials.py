"""trials: a session replayed trial by trial, written with the real writer."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from twopose.camera import Camera, Intrinsics
from twopose.format.entries import GroundTruth, Note, PoseEntry, SessionInfo
from twopose.format.reader import SessionReader
from twopose.format.trials import describe_session, iter_trials
from twopose.format.writer import SessionWriter

CAM = Camera("cam0", Intrinsics(32, 24, 30.0, 30.0, 16.0, 12.0))


def _capture(w: SessionWriter, trial: int, pose: int, n: int, t0: int, fail: bool = False) -> None:
    w.write_pose(PoseEntry(trial, pose, "cam0", (float(pose), 0.0, 0.0)), t0)
    with w.capture(trial, pose, "cam0") as cap:
        for k in range(n):
            cap.add_frame(np.full((24, 32, 3), 10 * k, np.uint8), t0 + 1 + k)
        if fail:
            cap.mark_incomplete("camera unplugged")


def _session(path: Path) -> None:
    info = SessionInfo(method="point", units="in", notes="session note")
    with SessionWriter(path, info, [CAM], image_format="png", start_ns=0) as w:
        w.write_ground_truth(GroundTruth(1, "point", ((1.0, 2.0, 3.0),)), 5)
        _capture(w, 1, 1, 3, 10)
        _capture(w, 1, 2, 2, 20)
        _capture(w, 1, 2, 4, 30)  # redone: replaces the capture above
        w.write_note(Note("glare on pose 2", 1), 40)
        _capture(w, 2, 1, 2, 50)
        _capture(w, 2, 2, 1, 60, fail=True)


def test_trials_bind_frames_to_their_capture(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    _session(path)
    with SessionReader(path) as r:
        trials = list(iter_trials(r))
    assert [t.trial for t in trials] == [1, 2]
    one, two = trials
    assert one.ground_truth is not None
    assert one.ground_truth.points_grid == ((1.0, 2.0, 3.0),)
    assert [len(p.frames) for p in one.poses] == [3, 4]  # the redone capture wins
    assert [f.log_time_ns for f in one.poses[1].frames] == [31, 32, 33, 34]
    assert all(p.complete for p in one.poses)
    assert one.notes == ("glare on pose 2",)
    assert two.ground_truth is None
    assert [p.complete for p in two.poses] == [True, False]
    assert two.poses[1].window is not None
    assert two.poses[1].window.reason == "camera unplugged"


def test_trials_without_frames_and_the_overview(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    _session(path)
    with SessionReader(path) as r:
        trials = list(iter_trials(r, with_frames=False))
    assert [len(p.frames) for t in trials for p in t.poses] == [0, 0, 0, 0]
    o = describe_session(path)
    assert (o.n_trials, o.n_poses, o.n_captures, o.n_incomplete_captures) == (2, 4, 4, 1)
    assert o.n_frames == 3 + 2 + 4 + 2 + 1  # every frame written, redone ones included
    assert o.info.notes == "session note"
