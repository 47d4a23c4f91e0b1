"""trials: a session replayed trial by trial, written with the real writer."""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np

from twopose.camera.model import Camera, Intrinsics
from twopose.format.entries import (
    CaptureDecision,
    GroundTruth,
    Note,
    PoseEntry,
    SessionInfo,
)
from twopose.format.reader import SessionReader
from twopose.format.trials import describe_session, iter_trials
from twopose.format.writer import SessionWriter
from twopose.methods.specs import Method
from twopose.values.units import Units

CAM = Camera(
    camera_id="cam0", intrinsics=Intrinsics(width=32, height=24, fx=30.0, fy=30.0, cx=16.0, cy=12.0)
)


def _capture(w: SessionWriter, trial: int, pose: int, n: int, t0: int, fail: bool = False) -> None:
    w.write_pose(
        PoseEntry(trial=trial, pose=pose, camera_id="cam0", t_grid=(float(pose), 0.0, 0.0)), t0
    )
    with w.capture(trial, pose, "cam0") as cap:
        for k in range(n):
            cap.add_frame(np.full((24, 32, 3), 10 * k, np.uint8), t0 + 1 + k)
        if fail:
            cap.mark_incomplete("camera unplugged")


def _numbered(
    w: SessionWriter,
    trial: int,
    pose: int,
    t0: int,
    decision: Literal["accept", "discard"] | None,
    *,
    frames: int = 2,
) -> int:
    """A format 1.1 capture: the pose entry and window bound by number, then the decision."""
    number = w.new_capture_number()
    w.write_pose(
        PoseEntry(
            trial=trial, pose=pose, camera_id="cam0", t_grid=(float(t0), 0.0, 0.0), capture=number
        ),
        t0,
    )
    with w.capture(trial, pose, "cam0", number) as cap:
        for k in range(frames):
            cap.add_frame(np.full((24, 32, 3), 10 * k, np.uint8), t0 + 1 + k)
    if decision is not None:
        w.write_decision(
            CaptureDecision(
                capture=number,
                trial=trial,
                pose=pose,
                camera_id="cam0",
                decision=decision,
                reason="test",
            ),
            t0 + 9,
        )
    return number


def _session(path: Path) -> None:
    info = SessionInfo(method=Method.POINT, units=Units.IN, notes="session note")
    with SessionWriter(path, info, [CAM], image_format="png", start_ns=0) as w:
        w.write_ground_truth(GroundTruth(trial=1, kind="point", points_grid=((1.0, 2.0, 3.0),)), 5)
        _capture(w, 1, 1, 3, 10)
        _capture(w, 1, 2, 2, 20)
        _capture(w, 1, 2, 4, 30)  # redone: replaces the capture above
        w.write_note(Note(text="glare on pose 2", trial=1), 40)
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
    assert (o.n_trials, o.n_poses, o.n_captures, o.n_incomplete_captures) == (
        2,
        4,
        5,
        1,
    )  # 5 windows: one redone
    assert o.n_frames == 3 + 2 + 4 + 2 + 1  # every frame written, redone ones included
    assert o.info.notes == "session note"


def _replayed(path: Path) -> list[tuple[int, list[tuple[int, float, int]]]]:
    """Per trial: (pose, typed x, number of frames) of every pose it is measured from."""
    with SessionReader(path) as r:
        return [
            (t.trial, [(p.entry.pose, p.entry.t_grid[0], len(p.frames)) for p in t.poses])
            for t in iter_trials(r)
        ]


def test_format_1_1_replays_exactly_the_accepted_captures(tmp_path: Path) -> None:
    """The issue's scenario at the format level: accept, undo, retype, interrupted."""
    path = tmp_path / "s.mcap"
    info = SessionInfo(method=Method.POINT, units=Units.IN)
    with SessionWriter(path, info, [CAM], image_format="png", start_ns=0) as w:
        _numbered(w, 1, 1, 10, "accept")
        _numbered(w, 1, 2, 20, "discard")  # redone
        _numbered(w, 1, 2, 30, "accept", frames=3)
        a = _numbered(w, 2, 1, 40, "accept")
        _numbered(w, 2, 2, 50, "discard")  # undo ...
        w.write_decision(
            CaptureDecision(
                capture=a, trial=2, pose=1, camera_id="cam0", decision="discard", reason="undone"
            ),
            59,
        )
        # ... pose 1 retyped, then the capture cut short by Ctrl-C and never decided
        number = w.new_capture_number()
        w.write_pose(
            PoseEntry(trial=2, pose=1, camera_id="cam0", t_grid=(0.5, 0.0, 0.0), capture=number), 60
        )
    replayed = _replayed(path)
    assert replayed == [(1, [(1, 10.0, 2), (2, 30.0, 3)]), (2, [])]
    with SessionReader(path) as r:
        two = list(iter_trials(r))[1]
    reasons = [s.reason for s in two.set_aside]
    assert len(reasons) == 3
    assert "discarded (undone)" in reasons
    assert "discarded (test)" in reasons
    assert any("no capture was recorded" in x for x in reasons)
    assert "fewer than two accepted" in two.why_not_measured()


def test_an_undecided_or_incomplete_capture_is_never_measured(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    with SessionWriter(
        path,
        SessionInfo(method=Method.POINT, units=Units.IN),
        [CAM],
        image_format="png",
        start_ns=0,
    ) as w:
        _numbered(w, 1, 1, 10, "accept")
        _numbered(w, 1, 2, 20, None)  # the recorder died before the decision
        n = w.new_capture_number()
        w.write_pose(
            PoseEntry(trial=1, pose=3, camera_id="cam0", t_grid=(3.0, 0.0, 0.0), capture=n), 30
        )
        with w.capture(1, 3, "cam0", n) as cap:
            cap.add_frame(np.zeros((24, 32, 3), np.uint8), 31)
            cap.mark_incomplete("camera unplugged")
        w.write_decision(
            CaptureDecision(capture=n, trial=1, pose=3, camera_id="cam0", decision="accept"), 39
        )  # another writer
    assert _replayed(path) == [(1, [(1, 10.0, 2)])]
    o = describe_session(path)
    assert (o.n_poses, o.n_captures, o.n_incomplete_captures, o.n_set_aside) == (1, 3, 1, 2)


def test_notes_reach_their_trial_wherever_they_were_typed(tmp_path: Path) -> None:
    path = tmp_path / "s.mcap"
    with SessionWriter(
        path,
        SessionInfo(method=Method.POINT, units=Units.IN),
        [CAM],
        image_format="png",
        start_ns=0,
    ) as w:
        w.write_note(Note(text="before anything", trial=None), 1)
        _numbered(w, 1, 1, 10, "accept")
        _numbered(w, 2, 1, 20, "accept")
        w.write_note(Note(text="about trial 1, typed late", trial=1), 30)
    with SessionReader(path) as r:
        trials = list(iter_trials(r, with_frames=False))
    assert [t.notes for t in trials] == [("about trial 1, typed late",), ()]
    notes = describe_session(path).notes
    assert notes.session == ("before anything",)
    assert notes.by_trial == {1: ("about trial 1, typed late",)}


def test_a_typed_pose_beyond_any_grid_is_set_aside_with_why(tmp_path: Path) -> None:
    """Another writer's pose typed at 6000 mm (the recorder refuses past 5080 mm) is kept in
    the file but never measured from: solved with it, an "ok" trial would be nonsense."""
    path = tmp_path / "s.mcap"
    info = SessionInfo(method=Method.POINT, units=Units.MM)
    with SessionWriter(path, info, [CAM], image_format="png", start_ns=0) as w:
        _numbered(w, 1, 1, 10, "accept")  # typed at x 10 mm
        _numbered(w, 1, 2, 6000, "accept")  # typed at x 6000 mm
    with SessionReader(path) as reader:
        (record,) = iter_trials(reader)
    assert [pc.entry.pose for pc in record.poses] == [1]
    assert "its typed pose: camera centre x must be from -5080 to 5080 mm, got 6000" in (
        record.why_not_measured()
    )
