"""The laptop-on-grid procedure (thesis sections 3.4.2 and 5.2.5) as one loop: a trial's
ground truth, then pose after pose: place the camera, capture K frames with live detection
feedback, decide (accept, redo, undo, note, quit); next trial.

:func:`record` is that loop, the only one. What varies is who decides, a
:class:`Driver`: the operator at the terminal (:mod:`recorder.interactive`), a plan file
(:mod:`recorder.plan`), or the simulator (:mod:`recorder.simulate`). :func:`capture_pose`
is the capture step itself.
"""

from __future__ import annotations

import math
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING, Any

from recorder.sources import FrameSource, SourceInfo
from twopose.camera import Camera
from twopose.errors import SourceError
from twopose.format.entries import GroundPlane, Note, PoseEntry, SessionInfo, TypedEntry
from twopose.format.writer import SessionWriter
from twopose.values import Vec3

if TYPE_CHECKING:
    from recorder.live import LiveView

__all__ = [
    "CaptureResult",
    "Decision",
    "Driver",
    "FrameFeedback",
    "Placement",
    "RecordingSummary",
    "capture_pose",
    "record",
]


@dataclass(frozen=True)
class FrameFeedback:
    """What the operator sees for each captured frame."""

    index: int
    found: bool
    centroid_px: tuple[float, float]
    theta_deg: float
    n_blobs: int
    reason: str

    def line(self) -> str:
        if not self.found:
            return f"  frame {self.index + 1}: not found ({self.reason})"
        col, row = self.centroid_px
        theta = "" if math.isnan(self.theta_deg) else f", theta {self.theta_deg:+.1f} deg"
        where = f"({col:.1f}, {row:.1f})"
        return f"  frame {self.index + 1}: found at {where}{theta}, {self.n_blobs} blob(s)"


@dataclass(frozen=True)
class CaptureResult:
    """How a capture went."""

    n_frames: int
    complete: bool
    reason: str
    feedback: tuple[FrameFeedback, ...] = ()
    dropped: int = 0
    overhead_s: tuple[float, ...] = ()  # per frame: encode + write + detection

    @property
    def n_found(self) -> int:
        return sum(f.found for f in self.feedback)


def capture_pose(
    writer: SessionWriter,
    source: FrameSource,
    entry: PoseEntry,
    n_frames: int,
    *,
    target: str | None = None,
    on_frame: Callable[[FrameFeedback], None] | None = None,
    timeout_s: float = 2.0,
    live: LiveView | None = None,
) -> CaptureResult:
    """Write the typed pose, then capture ``n_frames`` frames from ``source`` (already
    placed at the pose: :func:`record` does that).

    ``target`` (``"glove"`` or ``"dot"``) turns on live detection feedback. A source that
    fails mid-capture leaves the capture in the file, marked incomplete with the reason.
    With ``live``, every frame, its detection overlay and the status go to the live view.
    """
    from twopose.detect import detect

    writer.write_pose(entry)

    feedback: list[FrameFeedback] = []
    overhead: list[float] = []
    reason = ""
    count = 0
    dropped_before = source.dropped
    with writer.capture(entry.trial, entry.pose, entry.camera_id) as cap:
        for k in range(n_frames):
            try:
                image = source.read(timeout_s)
            except SourceError as err:
                reason = str(err)
                cap.mark_incomplete(reason)
                break
            started = time.perf_counter()
            data = writer.encode_image(image)
            cap.add_encoded(data)
            count += 1
            d = None
            if target is not None:
                d = detect(image, target)
                fb = FrameFeedback(k, d.found, d.centroid_px, d.theta_deg, d.n_blobs, d.reason)
                feedback.append(fb)
            if live is not None:
                where = f"trial {entry.trial} pose {entry.pose} frame {k + 1}/{n_frames}"
                t = cap.end_ns or 0
                live.frame(entry.camera_id, data, writer.image_format, t, d, where)
                live.status(
                    t,
                    trial=entry.trial,
                    pose=entry.pose,
                    frame=k + 1,
                    n_frames=n_frames,
                    found=None if d is None else d.found,
                    message=where + ("" if d is None else ": " + (d.reason or "found")),
                )
            overhead.append(time.perf_counter() - started)
            if target is not None and on_frame is not None:
                on_frame(fb)
            cap.dropped_frames = source.dropped - dropped_before
    return CaptureResult(
        count, not reason, reason, tuple(feedback), source.dropped - dropped_before, tuple(overhead)
    )


# --------------------------------------------------------------------------- the loop


class Decision(StrEnum):
    """What happens after a capture."""

    ACCEPT = "a"  # next pose
    REDO = "r"  # capture this pose again
    UNDO = "u"  # go back to the previous pose
    NOTE = "n"  # add a note, then decide again
    QUIT = "q"  # end the session


@dataclass(frozen=True)
class Placement:
    """Where the camera goes for a pose: the typed entry, and where it really is (the
    simulator renders from the true pose; a real operator's camera is where it is)."""

    entry: PoseEntry
    true_pose: tuple[Vec3, Vec3] | None = None  # (t_grid, r_deg)


class Driver:
    """Who decides during :func:`record`. Subclasses override what they decide; the
    defaults record one trial of two poses and accept every capture."""

    poses_per_trial = 2

    def start(self, source: SourceInfo, path: Path) -> None:
        """The session file and the source are open."""

    def next_trial(self, trial: int) -> bool:
        """Whether to record trial ``trial`` (numbered from 1)."""
        return trial == 1

    def trial_entries(self, trial: int) -> Sequence[TypedEntry]:
        """Entries written when the trial begins (its ground truth)."""
        return ()

    def poses_in(self, trial: int) -> int:
        return self.poses_per_trial

    def place(self, trial: int, pose: int) -> Placement:
        raise NotImplementedError

    def captured(self, trial: int, pose: int, result: CaptureResult) -> None:
        """A capture ended (report it)."""

    def decide(self, trial: int, pose: int, result: CaptureResult) -> Decision:
        return Decision.ACCEPT

    def note(self, trial: int) -> Note:
        """The note to write after :attr:`Decision.NOTE`."""
        raise NotImplementedError

    def end_trial(self, trial: int) -> Sequence[TypedEntry]:
        """Entries written when the trial is done (the simulation truth)."""
        return ()

    def finish(self, summary: RecordingSummary) -> None:
        """The session is closed."""


@dataclass(frozen=True)
class RecordingSummary:
    """What a recording holds."""

    path: Path
    n_trials: int
    n_captures: int
    n_incomplete: int
    n_frames: int
    n_found: int
    seconds: float
    dropped: int = 0


@dataclass
class _Tally:
    started: float = field(default_factory=time.monotonic)
    captures: int = 0
    incomplete: int = 0
    frames: int = 0
    found: int = 0
    dropped: int = 0
    trials: set[int] = field(default_factory=set)

    def add(self, result: CaptureResult) -> None:
        self.captures += 1
        self.incomplete += not result.complete
        self.frames += result.n_frames
        self.found += result.n_found
        self.dropped += result.dropped

    def summary(self, path: Path) -> RecordingSummary:
        return RecordingSummary(
            path,
            len(self.trials),
            self.captures,
            self.incomplete,
            self.frames,
            self.found,
            time.monotonic() - self.started,
            self.dropped,
        )


def record(
    path: str | Path,
    info: SessionInfo,
    cameras: Sequence[Camera],
    source: FrameSource,
    driver: Driver,
    *,
    ground: GroundPlane | None = None,
    frames: int = 5,
    target: str | None = None,
    live: LiveView | None = None,
    on_frame: Callable[[FrameFeedback], None] | None = None,
    writer_options: dict[str, Any] | None = None,
) -> RecordingSummary:
    """Record a new session at ``path`` from the (unopened) ``source``, as ``driver`` says.

    ``target`` (``"glove"`` or ``"dot"``) turns on live detection feedback. A capture that
    fails is kept in the file, marked incomplete; whatever stops the loop (the driver, an
    error, Ctrl-C) leaves a closed, valid session with everything captured so far.
    """
    tally = _Tally()
    out = Path(path)
    with source, SessionWriter(out, info, cameras, ground=ground, **(writer_options or {})) as w:
        driver.start(source.info, out)
        trial = 0
        while driver.next_trial(trial + 1):
            trial += 1
            tally.trials.add(trial)
            for entry in driver.trial_entries(trial):
                w.write_entry(entry)
            if not _record_trial(w, source, driver, trial, tally, frames, target, live, on_frame):
                break
            for entry in driver.end_trial(trial):
                w.write_entry(entry)
    summary = tally.summary(out)
    driver.finish(summary)
    return summary


def _record_trial(
    writer: SessionWriter,
    source: FrameSource,
    driver: Driver,
    trial: int,
    tally: _Tally,
    frames: int,
    target: str | None,
    live: LiveView | None,
    on_frame: Callable[[FrameFeedback], None] | None,
) -> bool:
    """Pose after pose until the trial's last is accepted; False when the driver quits."""
    pose = 1
    while pose <= driver.poses_in(trial):
        placed = driver.place(trial, pose)
        t_grid, r_deg = placed.true_pose or (placed.entry.t_grid, placed.entry.r_deg)
        source.set_pose(t_grid, r_deg)
        result = capture_pose(
            writer, source, placed.entry, frames, target=target, on_frame=on_frame, live=live
        )
        tally.add(result)
        driver.captured(trial, pose, result)
        decision = driver.decide(trial, pose, result)
        while decision is Decision.NOTE:
            writer.write_note(driver.note(trial))
            decision = driver.decide(trial, pose, result)
        if decision is Decision.QUIT:
            return False
        if decision is Decision.ACCEPT:
            pose += 1
        elif decision is Decision.UNDO:
            pose = max(pose - 1, 1)
    return True
