"""The laptop-on-grid procedure (thesis sections 3.4.2 and 5.2.5) as one state machine.

A trial's ground truth, then pose after pose: type the pose, capture K frames, decide
(accept, redo, undo, note, quit); next trial. :class:`Procedure` is that machine and the
only writer of the operator's record. Every event is checked against the state
(:data:`TRANSITIONS`), and every event that changes what the analysis will use is written
to the session at once (format 1.1, ``docs/session-format.md``):

=========  ==============================  ==========  =====================================
state      event                           next state  written
=========  ==============================  ==========  =====================================
ready      begin_trial                     typing      the trial's ground truth
typing     type_pose                       placed      the pose entry, bound to capture n
placed     type_pose (retyped)             placed      a new entry (capture n+1); n unused
placed     capture                         deciding    the frames and capture window n
deciding   accept (complete capture)       typing      decision: accept n
                                           / ready     (after the trial's last pose)
deciding   redo                            typing      decision: discard n (redo)
deciding   undo (pose > 1)                 typing      discard n (undo), and discard the
                                                       previous pose's capture (undone)
any open   note                            unchanged   the note
any open   quit / interrupt / error        closed      discard n if undecided
=========  ==============================  ==========  =====================================

Refused (:class:`recorder.procedure.driver.ProcedureRefusedError`, the state is unchanged):
accepting an incomplete capture, and undo at a trial's first pose (there is nothing to
undo). A kill -9 leaves the
file as the last flush left it: ``recover`` closes it, and whatever was not yet accepted is
not measured.

:func:`recorder.procedure.recording.record` drives the machine.
"""

from __future__ import annotations

from collections.abc import Iterable
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING

from recorder.procedure.capture import (
    CaptureInterrupted,
    CaptureResult,
    CaptureSettings,
    FrameFeedback,
    Shortfall,
    capture_frames,
    detection_shortfall,
)
from recorder.procedure.driver import (
    LowDetectionError,
    ProcedureError,
    ProcedureRefusedError,
)
from recorder.procedure.summary import RecordingSummary, Tally
from recorder.sources.registry import FrameSource
from twopose.errors import SessionExistsError
from twopose.format.entries import (
    CaptureDecision,
    Note,
    PoseEntry,
    TypedEntry,
    Verdict,
)
from twopose.format.writer import SessionWriter
from twopose.values.checks import Vec3

if TYPE_CHECKING:
    pass

__all__ = [
    "TRANSITIONS",
    "CaptureResult",
    "FrameFeedback",
    "Procedure",
    "RecordingSummary",
    "Shortfall",
    "State",
    "detection_shortfall",
    "refuse_existing",
]


class State(StrEnum):
    READY = "ready"  # between trials
    TYPING = "typing"  # a trial is open; its next pose is to be typed
    PLACED = "placed"  # the pose is typed (written), not yet captured
    DECIDING = "deciding"  # captured; waiting for the operator's decision
    CLOSED = "closed"


#: The events each state allows (what :class:`Procedure` checks before every event).
TRANSITIONS: dict[State, frozenset[str]] = {
    State.READY: frozenset({"begin_trial", "write", "note", "close"}),
    State.TYPING: frozenset({"type_pose", "complete_trial", "write", "note", "close"}),
    State.PLACED: frozenset({"type_pose", "capture", "note", "close"}),
    State.DECIDING: frozenset({"accept", "redo", "undo", "note", "close"}),
    State.CLOSED: frozenset(),
}


class Procedure:
    """The recording procedure over an open :class:`SessionWriter` (see the module docs)."""

    def __init__(self, writer: SessionWriter, tally: Tally | None = None) -> None:
        self.writer = writer
        #: what was written: every capture window and each capture's last decision (the
        #: summary's counts, as the file holds them)
        self.tally = tally if tally is not None else Tally()
        self.state = State.READY
        self.trial = 0
        self.pose = 0
        self.n_poses = 0
        self.entry: PoseEntry | None = None  # the typed pose being captured or decided
        self.result: CaptureResult | None = None
        self.accepted: dict[int, PoseEntry] = {}  # this trial: pose -> accepted entry
        #: the session: capture number -> its accepted entry and how the capture went
        self.kept: dict[int, tuple[PoseEntry, CaptureResult]] = {}
        self.n_complete_trials = 0
        self.n_operator_entries = 0  # typed poses and notes: what an empty session lacks

    @property
    def n_accepted(self) -> int:
        """Captures in the file whose last decision is accept."""
        return self.tally.n_accepted

    @property
    def n_discarded(self) -> int:
        """Captures in the file whose last decision is discard."""
        return self.tally.n_discarded

    def _event(self, name: str) -> None:
        if name not in TRANSITIONS[self.state]:
            raise ProcedureError(f"cannot {name.replace('_', ' ')} while {self.state.value}")

    # -- trials and poses
    def begin_trial(self, trial: int, n_poses: int, entries: Iterable[TypedEntry] = ()) -> None:
        """Open trial ``trial`` of ``n_poses`` poses; ``entries`` (its ground truth) go first."""
        self._event("begin_trial")
        if trial <= self.trial:
            raise ProcedureError(f"trial {trial} does not follow trial {self.trial}")
        if n_poses < 1:
            raise ProcedureError(f"a trial needs at least one pose, got {n_poses}")
        self.trial, self.pose, self.n_poses, self.accepted = trial, 1, n_poses, {}
        for entry in entries:
            self.writer.write_entry(entry)
        self.state = State.TYPING

    def type_pose(self, entry: PoseEntry) -> PoseEntry:
        """Write the typed pose bound to a new capture number; returns the bound entry."""
        self._event("type_pose")
        if (entry.trial, entry.pose) != (self.trial, self.pose):
            raise ProcedureError(
                f"expected trial {self.trial} pose {self.pose}, got trial {entry.trial} "
                f"pose {entry.pose}"
            )
        bound = PoseEntry(
            trial=entry.trial,
            pose=entry.pose,
            camera_id=entry.camera_id,
            t_grid=entry.t_grid,
            r_deg=entry.r_deg,
            translation_resolution=entry.translation_resolution,
            rotation_resolution_deg=entry.rotation_resolution_deg,
            capture=self.writer.new_capture_number(),
        )
        self.writer.write_pose(bound)
        self.n_operator_entries += 1
        self.entry, self.result = bound, None
        self.state = State.PLACED
        return bound

    def capture(
        self,
        source: FrameSource,
        settings: CaptureSettings,
        *,
        true_pose: tuple[Vec3, Vec3] | None = None,
    ) -> CaptureResult:
        """Place ``source`` at the pose (the simulator's true pose, if given) and capture.

        An interrupt during the capture leaves its window in the file (incomplete, with the
        frames it got, and counted so) and the machine deciding, so that closing discards it.
        """
        self._event("capture")
        assert self.entry is not None
        t_grid, r_deg = true_pose or (self.entry.t_grid, self.entry.r_deg)
        try:
            source.set_pose(t_grid, r_deg)
            self.result = capture_frames(self.writer, source, self.entry, settings)
        except CaptureInterrupted as stop:
            self.result = stop.result  # its window is in the file
            raise
        finally:
            self.state = State.DECIDING
            if self.result is not None:  # a window was written
                self.tally.add(self.result)
        return self.result

    # -- decisions
    def _decide(self, entry: PoseEntry, verdict: Verdict, reason: str = "") -> None:
        assert entry.capture is not None
        self.writer.write_decision(
            CaptureDecision(
                capture=entry.capture,
                trial=entry.trial,
                pose=entry.pose,
                camera_id=entry.camera_id,
                decision=verdict,
                reason=reason,
            )
        )
        self.tally.decided(entry.capture, verdict)

    def accept(self, *, anyway: bool = False, unattended: bool = False) -> None:
        """Accept the capture: next pose, or the trial is complete (back to ready).

        A capture whose target was found in fewer than half its frames needs ``anyway``
        (the operator confirmed it); one where it was never found is refused, except
        ``unattended`` (a plan, which cannot ask, records it; its driver says so).
        """
        self._event("accept")
        assert self.entry is not None
        assert self.result is not None
        if not self.result.complete:
            raise ProcedureRefusedError(
                f"capture {self.entry.capture} is incomplete ({self.result.reason}); "
                "redo it, or quit"
            )
        shortfall = detection_shortfall(self.result)
        if shortfall is Shortfall.NONE_FOUND and not unattended:
            what = self.result.sought
            raise ProcedureRefusedError(
                f"{what} was found in none of the {self.result.n_frames} frames, so "
                f"this pose has nothing to measure: redo it (is {what} in view?)"
            )
        if shortfall is Shortfall.FEW_FOUND and not (anyway or unattended):
            raise LowDetectionError(
                f"{self.result.sought} was found in only {self.result.n_found} of "
                f"{self.result.n_frames} frames: accept anyway, or redo"
            )
        self._decide(self.entry, "accept")
        self.writer.sync()  # an accepted capture survives a power cut too
        self.accepted[self.pose] = self.entry
        assert self.entry.capture is not None
        self.kept[self.entry.capture] = (self.entry, self.result)
        self.entry = None
        if self.pose >= self.n_poses:
            self.n_complete_trials += 1
            self.state = State.READY
        else:
            self.pose += 1
            self.state = State.TYPING

    def complete_trial(self) -> None:
        """End the trial before its last planned pose: the stop rule says it is precise
        enough (:mod:`twopose.guidance.advice`); it needs two accepted poses."""
        self._event("complete_trial")
        if len(self.accepted) < 2:
            raise ProcedureError(f"trial {self.trial} has {len(self.accepted)} pose(s): two needed")
        self.n_complete_trials += 1
        self.state = State.READY

    def redo(self) -> None:
        """Discard the capture; the same pose is typed (it may be corrected) and captured."""
        self._event("redo")
        assert self.entry is not None
        self._decide(self.entry, "discard", "redo")
        self.entry = None
        self.state = State.TYPING

    def undo(self) -> None:
        """Discard the capture and the previous pose's accepted one; retype that pose."""
        self._event("undo")
        assert self.entry is not None
        if self.pose == 1:
            raise ProcedureRefusedError(
                f"nothing to undo: pose 1 is the first pose of trial {self.trial}; "
                "redo captures it again"
            )
        self._decide(self.entry, "discard", "undo")
        previous = self.accepted.pop(self.pose - 1)
        self._decide(previous, "discard", f"undone by capture {self.entry.capture}")
        self.kept.pop(previous.capture or -1, None)
        self.entry = None
        self.pose -= 1
        self.state = State.TYPING

    def note(self, text: str) -> None:
        """An operator note about the current trial (about the session before the first)."""
        self._event("note")
        self.writer.write_note(Note(text=text, trial=self.trial or None))
        self.n_operator_entries += 1

    def write(self, entry: TypedEntry) -> None:
        """A typed entry between poses (a trial's ground truth or simulation truth)."""
        self._event("write")
        self.writer.write_entry(entry)

    def close(self, reason: str) -> None:
        """End the procedure: an undecided capture is discarded with ``reason``."""
        if self.state is State.CLOSED:
            return
        if self.state is State.DECIDING and self.entry is not None and self.writer.is_open:
            self._decide(self.entry, "discard", reason)
        self.entry = None
        self.state = State.CLOSED


# --------------------------------------------------------------------------- the loop


def refuse_existing(path: str | Path) -> None:
    """Refuse a session path that exists (call it before asking the operator anything)."""
    if Path(path).exists():
        raise SessionExistsError(
            f"{path} already exists; twopose never overwrites a session. "
            "Choose another file name or move the old one away."
        )
