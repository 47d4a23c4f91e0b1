"""Trials: stream a session file trial by trial, pose by pose, frame by frame.

Messages come in log-time order from the seeking reader, one chunk in memory at a time.
Frames are held only until their capture is decided (format 1.1) or its window closes
(1.0), and a trial is handed out as soon as the next trial begins, so peak memory is one
trial's frames, whatever the session length.

Which captures a trial is measured from (``docs/session-format.md``):

* format 1.1: exactly the captures the operator accepted. A capture is bound to its pose
  entry by its capture number; it is used only if it has a pose entry, a complete window
  with frames, and the last decision naming it is ``accept``. Everything else (redone,
  undone, interrupted, undecided) is kept in :attr:`TrialRecord.set_aside` with the reason.
* format 1.0 (no capture numbers): a later pose entry or window for the same trial and pose
  replaces the earlier one, as that version specified.
"""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING

from twopose.camera.model import Camera
from twopose.format.entries import (
    CaptureDecision,
    CaptureWindow,
    GroundTruth,
    Note,
    PlaneEntry,
    PoseEntry,
    SessionInfo,
    SimulationTruth,
)
from twopose.format.messages import Frame, image_topic
from twopose.format.reader import SessionReader
from twopose.values.bounds import POSE_TRANSLATION, ROTATION
from twopose.values.units import UnitSpec, unit_spec

if TYPE_CHECKING:
    from twopose.format.streams import PairSession

__all__ = [
    "PoseCapture",
    "SessionNotes",
    "SessionOverview",
    "SetAside",
    "TrialRecord",
    "beyond_any_grid",
    "describe_session",
    "iter_trials",
    "read_notes",
]


@dataclass(frozen=True, kw_only=True)
class PoseCapture:
    """One pose of a trial: the typed pose, its camera, and the frames captured there."""

    entry: PoseEntry
    camera: Camera
    window: CaptureWindow | None
    frames: tuple[Frame, ...]

    @property
    def complete(self) -> bool:
        """Whether the capture ended complete and has frames."""
        return self.window is not None and self.window.status == "complete" and bool(self.frames)


@dataclass(frozen=True, kw_only=True)
class SetAside:
    """A capture (or a typed pose without one) that is kept in the file but not measured."""

    pose: int
    capture: int | None
    n_frames: int
    reason: str

    def describe(self) -> str:
        """The capture in words, with why it was set aside."""
        which = f"capture {self.capture}" if self.capture is not None else "a capture"
        return f"pose {self.pose} ({which}, {self.n_frames} frames): {self.reason}"


@dataclass(frozen=True, kw_only=True)
class TrialRecord:
    """Everything recorded for one trial.

    The poses it is measured from, in pose order, and (format 1.1) what was set aside.
    """

    trial: int
    poses: tuple[PoseCapture, ...]
    ground_truth: GroundTruth | None
    simulation_truth: SimulationTruth | None
    notes: tuple[str, ...] = ()
    set_aside: tuple[SetAside, ...] = ()

    def why_not_measured(self) -> str:
        """Why fewer than two poses are usable (empty when two or more are)."""
        usable = [p for p in self.poses if p.complete]
        if len(usable) >= 2:
            return ""
        have = ", ".join(f"pose {p.entry.pose}" for p in usable) or "none"
        if not self.set_aside:
            return f"fewer than two complete captures (usable: {have})"
        lost = "; ".join(s.describe() for s in self.set_aside)
        return f"fewer than two accepted, complete captures (usable: {have}); set aside: {lost}"


@dataclass(frozen=True, kw_only=True)
class SessionNotes:
    """The operator's notes: per trial, and about the whole session."""

    by_trial: dict[int, tuple[str, ...]]
    session: tuple[str, ...]


def read_notes(reader: SessionReader) -> SessionNotes:
    """Every note of the session (the note topic only: cheap), wherever it was typed."""
    by_trial: dict[int, list[str]] = {}
    session: list[str] = []
    for item in reader.iter_entries(topics=[Note.TOPIC]):
        if isinstance(item, Note):
            if item.trial is None:
                session.append(item.text)
            else:
                by_trial.setdefault(item.trial, []).append(item.text)
    return SessionNotes(by_trial={k: tuple(v) for k, v in by_trial.items()}, session=tuple(session))


@dataclass(kw_only=True)
class _Capture:
    """What is known of one numbered capture (format 1.1)."""

    entry: PoseEntry | None = None
    window: CaptureWindow | None = None
    frames: tuple[Frame, ...] = ()
    decision: CaptureDecision | None = None

    def reason_unused(self, cameras: dict[str, Camera], unit: UnitSpec) -> str:
        """Why this capture is not measured; empty if it is usable."""
        if self.entry is None:
            return "its pose entry is missing"
        if self.entry.camera_id not in cameras:
            return f"its camera {self.entry.camera_id!r} has no calibration in the session"
        if beyond := beyond_any_grid(self.entry, unit):
            return beyond
        if self.window is None:
            return "no capture was recorded for this typed pose (the recording stopped)"
        if self.decision is None:
            return "the recording stopped before the operator decided"
        if not self.decision.accepted:
            return f"discarded ({self.decision.reason or 'by the operator'})"
        if self.window.status != "complete":
            return f"incomplete ({self.window.reason or 'cut short'})"
        if self.window.n_frames == 0:
            return "it holds no frames"
        return ""


def beyond_any_grid(entry: PoseEntry, unit: UnitSpec) -> str:
    """Why a typed pose cannot be measured from ("": it can).

    Its translation or rotation is past the bound the recorder takes
    (:mod:`twopose.values.bounds`). The recorder refuses such a pose; another writer's file may
    hold one, and solved with it an "ok" trial would be nonsense.
    """
    why = POSE_TRANSLATION.vector_refusal(entry.t_grid, unit.units)
    why = why or ROTATION.vector_refusal(entry.r_deg, unit.units)
    return f"its typed pose: {why}" if why else ""


@dataclass(kw_only=True)
class _TrialBuilder:
    trial: int
    unit: UnitSpec  # the session's
    poses: dict[int, PoseEntry] = field(default_factory=dict)  # format 1.0
    captures_1_0: dict[int, tuple[CaptureWindow, tuple[Frame, ...]]] = field(default_factory=dict)
    captures: dict[int, _Capture] = field(default_factory=dict)  # format 1.1, by number
    ground_truth: GroundTruth | None = None
    simulation_truth: SimulationTruth | None = None

    def numbered(self, number: int) -> _Capture:
        return self.captures.setdefault(number, _Capture())

    def add_pose(self, entry: PoseEntry) -> None:
        if entry.capture is None:
            self.poses[entry.pose] = entry  # 1.0: a corrected typo replaces the earlier
        else:
            self.numbered(entry.capture).entry = entry

    def add_window(self, window: CaptureWindow, frames: tuple[Frame, ...]) -> None:
        if window.capture is None:
            self.captures_1_0[window.pose] = (window, frames)  # 1.0: a redo replaces
        else:
            c = self.numbered(window.capture)
            c.window, c.frames = window, frames

    def add_decision(self, decision: CaptureDecision) -> None:
        c = self.numbered(decision.capture)
        c.decision = decision
        if not decision.accepted:
            c.frames = ()  # never analysed: do not hold its frames

    def build(self, cameras: dict[str, Camera], notes: tuple[str, ...]) -> TrialRecord:
        poses, set_aside = self._accepted(cameras)
        for k in sorted(self.poses):  # format 1.0 files
            entry = self.poses[k]
            window, frames = self.captures_1_0.get(k, (None, ()))
            why = beyond_any_grid(entry, self.unit)
            if entry.camera_id not in cameras:
                why = f"its camera {entry.camera_id!r} has no calibration in the session"
            if why:
                set_aside.append(SetAside(pose=k, capture=None, n_frames=len(frames), reason=why))
                continue
            poses[k] = PoseCapture(
                entry=entry, camera=cameras[entry.camera_id], window=window, frames=frames
            )
        return TrialRecord(
            trial=self.trial,
            poses=tuple(poses[k] for k in sorted(poses)),
            ground_truth=self.ground_truth,
            simulation_truth=self.simulation_truth,
            notes=notes,
            set_aside=tuple(set_aside),
        )

    def _accepted(
        self, cameras: dict[str, Camera]
    ) -> tuple[dict[int, PoseCapture], list[SetAside]]:
        """Each pose's accepted capture, and everything set aside with its reason.

        Format 1.1: the accepted capture of each pose (the later one, should a writer have
        accepted two), and everything set aside with its reason.
        """
        poses: dict[int, tuple[int, PoseCapture]] = {}
        set_aside: list[SetAside] = []
        for number in sorted(self.captures):
            c = self.captures[number]
            pose = c.entry.pose if c.entry is not None else c.window.pose if c.window else -1
            n_frames = c.window.n_frames if c.window is not None else 0
            reason = c.reason_unused(cameras, self.unit)
            if reason:
                set_aside.append(
                    SetAside(pose=pose, capture=number, n_frames=n_frames, reason=reason)
                )
                continue
            assert c.entry is not None
            if pose in poses:
                earlier, _ = poses[pose]
                set_aside.append(
                    SetAside(
                        pose=pose,
                        capture=earlier,
                        n_frames=n_frames,
                        reason=f"replaced by {number}",
                    )
                )
            camera = cameras[c.entry.camera_id]
            poses[pose] = (
                number,
                PoseCapture(entry=c.entry, camera=camera, window=c.window, frames=c.frames),
            )
        return {k: pc for k, (_, pc) in poses.items()}, set_aside


_TRIAL_ENTRIES = (PoseEntry, CaptureWindow, CaptureDecision, GroundTruth, SimulationTruth)


def iter_trials(reader: SessionReader, *, with_frames: bool = True) -> Iterator[TrialRecord]:
    """Yield the session's trials in order (see the module docstring for what is used).

    Parameters
    ----------
    reader : SessionReader
        An open reader.
    with_frames : bool
        False skips the image topics entirely (fast: typed entries only).
    """
    cameras = reader.cameras
    unit = unit_spec(reader.info.units)
    notes = read_notes(reader).by_trial
    topics = [cls.TOPIC for cls in _TRIAL_ENTRIES]
    if with_frames:
        topics += [image_topic(cid) for cid in cameras]
    pending: dict[str, list[Frame]] = {cid: [] for cid in cameras}
    current: _TrialBuilder | None = None
    for item in reader.iter_entries(topics=topics):
        if isinstance(item, Frame):
            pending.setdefault(item.camera_id, []).append(item)
            continue
        if not isinstance(item, _TRIAL_ENTRIES):
            continue
        if current is not None and current.trial != item.trial:
            yield current.build(cameras, notes.get(current.trial, ()))
            current = None
        current = current or _TrialBuilder(trial=item.trial, unit=unit)
        if isinstance(item, PoseEntry):
            current.add_pose(item)
        elif isinstance(item, CaptureWindow):
            current.add_window(item, _take_frames(pending, item) if with_frames else ())
        elif isinstance(item, CaptureDecision):
            current.add_decision(item)
        elif isinstance(item, GroundTruth):
            current.ground_truth = item
        else:
            current.simulation_truth = item
    if current is not None:
        yield current.build(cameras, notes.get(current.trial, ()))


def _take_frames(pending: dict[str, list[Frame]], window: CaptureWindow) -> tuple[Frame, ...]:
    """The buffered frames inside ``window``; earlier ones (outside every window) go."""
    buffered = pending.get(window.camera_id, [])
    frames = tuple(f for f in buffered if window.start_ns <= f.log_time_ns <= window.end_ns)
    pending[window.camera_id] = [f for f in buffered if f.log_time_ns > window.end_ns]
    return frames


@dataclass(frozen=True, kw_only=True)
class SessionOverview:
    """What a session holds, without decoding a frame."""

    path: Path
    info: SessionInfo
    cameras: tuple[Camera, ...]
    ground: PlaneEntry | None
    format_version: str
    software_version: str
    n_trials: int
    n_poses: int  # poses measured from: accepted (1.1) or latest (1.0)
    n_captures: int  # capture windows in the file, kept or set aside
    n_incomplete_captures: int
    n_frames: int
    message_counts: dict[str, int]
    n_set_aside: int = 0
    notes: SessionNotes = field(default_factory=lambda: SessionNotes(by_trial={}, session=()))
    #: A two-camera session's pair, offset and stream trials (format 1.6; their images
    #: not read); None for a one-camera session.
    streams: PairSession | None = None


def describe_session(path: str | Path) -> SessionOverview:
    """Open a session (CRC-checked), walk its typed entries and count what it holds.

    A two-camera session's trials are its stream trials, its captures their windows.
    """
    with SessionReader(path) as reader:
        if reader.pair is not None:
            return _describe_pair_session(Path(path), reader)
        trials = list(iter_trials(reader, with_frames=False))
        counts = reader.message_counts()
        windows = [
            w
            for w in reader.iter_entries(topics=[CaptureWindow.TOPIC])
            if isinstance(w, CaptureWindow)
        ]
        return SessionOverview(
            path=Path(path),
            info=reader.info,
            cameras=tuple(reader.cameras.values()),
            ground=reader.ground,
            format_version=reader.format_version,
            software_version=reader.software_version,
            n_trials=len(trials),
            n_poses=sum(len(t.poses) for t in trials),
            n_captures=len(windows),
            n_incomplete_captures=sum(w.status != "complete" for w in windows),
            n_frames=sum(n for topic, n in counts.items() if topic.endswith("/image")),
            message_counts=counts,
            n_set_aside=sum(len(t.set_aside) for t in trials),
            notes=read_notes(reader),
        )


def _describe_pair_session(path: Path, reader: SessionReader) -> SessionOverview:
    """A two-camera session's overview: its stream trials, windows and frames."""
    from twopose.format.streams import read_pair_session

    session = read_pair_session(reader)
    counts = reader.message_counts()
    windows = [w for t in session.trials for s in t.cameras for w in s.windows]
    return SessionOverview(
        path=path,
        info=reader.info,
        cameras=session.cameras,
        ground=reader.ground,
        format_version=reader.format_version,
        software_version=reader.software_version,
        n_trials=len(session.trials),
        n_poses=0,
        n_captures=len(windows),
        n_incomplete_captures=sum(w.status != "complete" for w in windows),
        n_frames=sum(n for topic, n in counts.items() if topic.endswith("/image")),
        message_counts=counts,
        notes=read_notes(reader),
        streams=session,
    )
