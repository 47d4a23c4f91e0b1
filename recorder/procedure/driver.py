"""Who decides during :func:`recorder.procedure.recording.record`: the :class:`Driver` interface.

The operator at the terminal (:mod:`recorder.procedure.terminal`), in the browser
(:mod:`recorder.console.state`), a plan file (:mod:`recorder.setup.plan`) and the simulator
(:mod:`recorder.simulate.one_camera`) each implement it; the procedure asks it where each pose goes
(:class:`Placement`) and what to do after each capture (:class:`Decision`), and tells it
what it refuses (:class:`ProcedureRefusedError`).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from enum import StrEnum
from pathlib import Path
from typing import TYPE_CHECKING

from twopose.errors import InputValueError, TwoposeError
from twopose.format.entries import Note, PoseEntry, TypedEntry
from twopose.values.checks import Vec3

if TYPE_CHECKING:
    from recorder.live.trial_result import TrialResult
    from recorder.procedure.capture import CaptureResult
    from recorder.procedure.summary import RecordingSummary
    from recorder.sources.registry import SourceInfo
    from twopose.guidance.advice import Advice

__all__ = [
    "Decision",
    "Driver",
    "LowDetectionError",
    "Placement",
    "ProcedureError",
    "ProcedureRefusedError",
    "QuitRecording",
]


# What the procedure refuses or raises, and what a driver raises to end the recording.


class ProcedureError(TwoposeError):
    """An event the current state does not allow (a driver's mistake)."""


class QuitRecording(Exception):  # noqa: N818 - a request, not an error
    """Raised by a driver that ends the recording while asked for something else (the
    web console's quit button while a pose is being typed): closes like a quit."""


class ProcedureRefusedError(InputValueError):
    """A decision the operator cannot take now; the message says what to do instead."""


class LowDetectionError(ProcedureRefusedError):
    """Accept refused because the target was found in fewer than half the frames: the
    operator may confirm it (accept anyway)."""


# --------------------------------------------------------------------------- the driver


class Decision(StrEnum):
    """What the driver decides after a capture."""

    ACCEPT = "a"  # next pose
    ACCEPT_ANYWAY = "A"  # next pose, although the target was found in few frames
    REDO = "r"  # capture this pose again
    UNDO = "u"  # go back to the previous pose
    NOTE = "n"  # add a note, then decide again
    QUIT = "q"  # end the session (this capture is not used)


@dataclass(frozen=True, kw_only=True)
class Placement:
    """Where the camera goes for a pose: the typed entry, and where it really is (the
    simulator renders from the true pose; a real operator's camera is where it is)."""

    entry: PoseEntry
    true_pose: tuple[Vec3, Vec3] | None = None  # (t_grid, r_deg)


class Driver:
    """Who decides during :func:`record`. Subclasses override what they decide; the
    defaults record one trial of two poses and accept every capture."""

    poses_per_trial = 2
    #: The recording's first trial: 1, or after the last trial of the session a
    #: continuation continues (:func:`record`'s ``after_trial`` sets it).
    first_trial = 1
    #: True for a driver that cannot ask (a plan): a capture whose target was rarely or
    #: never found is recorded as accepted, and the driver says so in :meth:`captured`.
    unattended = False

    def start(self, source: SourceInfo, path: Path) -> None:
        """The session file and the source are open."""

    def next_trial(self, trial: int) -> bool:
        """Whether to record trial ``trial`` (numbered from :attr:`first_trial`)."""
        return trial == self.first_trial

    def trial_entries(self, trial: int) -> Sequence[TypedEntry]:  # noqa: ARG002 - the Driver's default ignores it
        """Entries written when the trial begins (its ground truth)."""
        return ()

    def poses_in(self, trial: int) -> int:  # noqa: ARG002 - the Driver's default ignores it
        return self.poses_per_trial

    def place(self, trial: int, pose: int) -> Placement:
        raise NotImplementedError

    def captured(self, trial: int, pose: int, result: CaptureResult) -> None:
        """A capture ended (report it)."""

    def decide(self, trial: int, pose: int, result: CaptureResult) -> Decision:  # noqa: ARG002 - the Driver's default ignores it
        return Decision.ACCEPT

    def refused(self, error: ProcedureRefusedError) -> None:
        """The last decision was refused; by default that ends the recording."""
        raise error

    def note(self, trial: int) -> Note:
        """The note to write after :attr:`Decision.NOTE`."""
        raise NotImplementedError

    def end_trial(self, trial: int) -> Sequence[TypedEntry]:  # noqa: ARG002 - the Driver's default ignores it
        """Entries written when the trial is done (the simulation truth)."""
        return ()

    def advice(self, trial: int, advice: Advice) -> bool:  # noqa: ARG002 - the default ignores it
        """Guidance after a decision (the next pose, or the trial precise enough); True to
        complete the trial now (the stop rule), which the default driver never does."""
        return False

    def advice_withdrawn(self, trial: int) -> None:
        """The trial's guidance is gone (an undo left it no accepted pose to advise from)."""

    def trial_result(self, result: TrialResult) -> None:
        """A trial's live result, new or updated (shown to the operator)."""

    def result_withdrawn(self, trial: int) -> None:
        """The trial's live result is gone (an undo left it fewer than two poses)."""

    def preview_result(self, result: TrialResult) -> None:
        """The result the trial would have if the capture awaiting a decision were
        accepted (from the trial's second pose on), shown before the decision."""

    def live_failed(self, message: str) -> None:
        """The live result or the overlay failed; the recording goes on (the analysis
        solves the file). Shown to the operator as a warning."""

    def computing(self, what: str) -> None:
        """A step the operator waits for has started (the next suggestion): the terminal
        says so; the page shows its own state, and a plan waits for no one."""

    def notice(self, message: str) -> None:
        """Something the operator should know that is no failure (a rig file without
        units, taken in the session's). Shown as a note."""

    def board_progress(self, seen_from: Sequence[Vec3], problem: str) -> None:
        """A board session after each decision: the typed camera centres of the accepted
        captures that saw the board, and why they cannot determine the rig yet (empty:
        they can), by the rule ``twopose-analyze rig`` applies
        (:func:`twopose.rig.board.check_identifiable`)."""

    def finish(self, summary: RecordingSummary) -> None:
        """The session is closed."""
