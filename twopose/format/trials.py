"""Trials: stream a session file trial by trial, pose by pose, frame by frame.

Messages come in log-time order from the seeking reader, one chunk in memory at a time.
Frames are held only until their capture window closes, and a trial is handed out as
soon as the next trial begins, so peak memory is one trial's frames, whatever the
session length.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

from twopose.camera import Camera
from twopose.format.entries import (
    CaptureWindow,
    GroundPlane,
    GroundTruth,
    Note,
    PoseEntry,
    SessionInfo,
    SimulationTruth,
)
from twopose.format.messages import Frame, image_topic
from twopose.format.reader import SessionReader

__all__ = [
    "PoseCapture",
    "SessionOverview",
    "TrialRecord",
    "describe_session",
    "iter_trials",
]


@dataclass(frozen=True)
class PoseCapture:
    """One pose of a trial: the typed pose, its camera, and the frames captured there."""

    entry: PoseEntry
    camera: Camera
    window: CaptureWindow | None
    frames: tuple[Frame, ...]

    @property
    def complete(self) -> bool:
        return self.window is not None and self.window.status == "complete" and bool(self.frames)


@dataclass(frozen=True)
class TrialRecord:
    """Everything recorded for one trial, in pose order."""

    trial: int
    poses: tuple[PoseCapture, ...]
    ground_truth: GroundTruth | None
    simulation_truth: SimulationTruth | None
    notes: tuple[str, ...] = ()


@dataclass
class _TrialBuilder:
    trial: int
    poses: dict[int, PoseEntry] = field(default_factory=dict)
    captures: dict[int, tuple[CaptureWindow, tuple[Frame, ...]]] = field(default_factory=dict)
    ground_truth: GroundTruth | None = None
    simulation_truth: SimulationTruth | None = None
    notes: list[str] = field(default_factory=list)

    def build(self, cameras: dict[str, Camera]) -> TrialRecord:
        poses = []
        for k in sorted(self.poses):
            entry = self.poses[k]
            window, frames = self.captures.get(k, (None, ()))
            poses.append(PoseCapture(entry, cameras[entry.camera_id], window, frames))
        return TrialRecord(
            self.trial, tuple(poses), self.ground_truth, self.simulation_truth, tuple(self.notes)
        )


def iter_trials(reader: SessionReader, *, with_frames: bool = True) -> Iterator[TrialRecord]:
    """Yield the session's trials in order (see the module docstring for memory use).

    Parameters
    ----------
    reader : SessionReader
        An open reader.
    with_frames : bool
        False skips the image topics entirely (fast: typed entries only).
    """
    cameras = reader.cameras
    topics = [
        PoseEntry.TOPIC,
        CaptureWindow.TOPIC,
        GroundTruth.TOPIC,
        SimulationTruth.TOPIC,
        Note.TOPIC,
    ]
    if with_frames:
        topics += [image_topic(cid) for cid in cameras]
    pending: dict[str, list[Frame]] = {cid: [] for cid in cameras}
    current: _TrialBuilder | None = None

    def switch(trial: int) -> Iterator[TrialRecord]:
        nonlocal current
        if current is not None and current.trial != trial:
            yield current.build(cameras)
            current = None
        if current is None:
            current = _TrialBuilder(trial)

    for item in reader.iter_entries(topics=topics):
        if isinstance(item, Frame):
            pending.setdefault(item.camera_id, []).append(item)
            continue
        if isinstance(item, Note):
            if current is not None and item.trial in (None, current.trial):
                current.notes.append(item.text)
            continue
        if not isinstance(item, PoseEntry | CaptureWindow | GroundTruth | SimulationTruth):
            continue
        yield from switch(item.trial)
        assert current is not None
        if isinstance(item, PoseEntry):
            current.poses[item.pose] = item
        elif isinstance(item, CaptureWindow):
            buffered = pending.get(item.camera_id, [])
            frames = tuple(f for f in buffered if item.start_ns <= f.log_time_ns <= item.end_ns)
            pending[item.camera_id] = [f for f in buffered if f.log_time_ns > item.end_ns]
            # A redone capture of the same pose replaces the earlier one.
            current.captures[item.pose] = (item, frames if with_frames else ())
        elif isinstance(item, GroundTruth):
            current.ground_truth = item
        else:
            current.simulation_truth = item
    if current is not None:
        yield current.build(cameras)


@dataclass(frozen=True)
class SessionOverview:
    """What a session holds, without decoding a frame."""

    path: Path
    info: SessionInfo
    cameras: tuple[Camera, ...]
    ground: GroundPlane | None
    format_version: str
    software_version: str
    n_trials: int
    n_poses: int
    n_captures: int
    n_incomplete_captures: int
    n_frames: int
    message_counts: dict[str, int]


def describe_session(path: str | Path) -> SessionOverview:
    """Open a session (CRC-checked), walk its typed entries and count what it holds."""
    with SessionReader(path) as reader:
        trials = list(iter_trials(reader, with_frames=False))
        counts = reader.message_counts()
        return SessionOverview(
            path=Path(path),
            info=reader.info,
            cameras=tuple(reader.cameras.values()),
            ground=reader.ground,
            format_version=reader.format_version,
            software_version=reader.software_version,
            n_trials=len(trials),
            n_poses=sum(len(t.poses) for t in trials),
            n_captures=sum(1 for t in trials for p in t.poses if p.window is not None),
            n_incomplete_captures=sum(
                1
                for t in trials
                for p in t.poses
                if p.window is not None and p.window.status != "complete"
            ),
            n_frames=sum(n for topic, n in counts.items() if topic.endswith("/image")),
            message_counts=counts,
        )
