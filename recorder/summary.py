"""What a recording holds and how it ended: the one summary line every recording path
prints (terminal, plan, browser), counted as the procedure decided."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

from recorder.capture import CaptureResult

__all__ = ["RecordingSummary", "Tally"]


class DecisionCounts(Protocol):
    """What the procedure counted (:class:`recorder.procedure.Procedure`)."""

    trial: int
    n_complete_trials: int
    n_accepted: int
    n_discarded: int


def _count(n: int, what: str) -> str:
    return f"{n} {what}{'' if n == 1 else 's'}"


@dataclass(frozen=True, kw_only=True)
class RecordingSummary:
    """What a recording holds, and how it ended. Each capture counts once, by its final
    decision: ``n_accepted + n_discarded == n_captures`` (an accepted capture later undone
    is discarded); ``n_incomplete`` counts captures that ended early, whatever became
    of them."""

    path: Path
    n_trials: int  # trials begun
    n_captures: int
    n_incomplete: int
    n_frames: int
    n_found: int
    seconds: float
    dropped: int = 0
    n_complete_trials: int = 0  # every pose accepted
    n_accepted: int = 0
    n_discarded: int = 0
    interrupted: bool = False
    kept: bool = True  # False: nothing was typed, so no (empty) session file was left

    def line(self) -> str:
        """The one summary line the command prints."""
        if not self.kept:
            return f"nothing was recorded: no session file written at {self.path}"
        ending = " (interrupted: the file is closed and valid)" if self.interrupted else ""
        return (
            f"wrote {self.path}: {_count(self.n_trials, 'trial')} "
            f"({self.n_complete_trials} complete), {_count(self.n_captures, 'capture')} "
            f"({self.n_accepted} accepted, {self.n_discarded} discarded; "
            f"{self.n_incomplete} incomplete), {_count(self.n_frames, 'frame')} "
            f"({self.n_found} detected, {self.dropped} dropped) in {self.seconds:.1f} s{ending}"
        )


@dataclass(kw_only=True)
class Tally:
    started: float = field(default_factory=time.monotonic)
    after_trial: int = 0  # a continuation's trials are numbered after this: not its own
    captures: int = 0
    incomplete: int = 0
    frames: int = 0
    found: int = 0
    dropped: int = 0

    def add(self, result: CaptureResult) -> None:
        self.captures += 1
        self.incomplete += not result.complete
        self.frames += result.n_frames
        self.found += result.n_found
        self.dropped += result.dropped

    def summary(
        self, path: Path, proc: DecisionCounts, *, interrupted: bool, kept: bool
    ) -> RecordingSummary:
        """The summary of a recording whose procedure is ``proc``."""
        return RecordingSummary(
            path=path,
            n_trials=max(0, proc.trial - self.after_trial),  # this file's trials
            n_captures=self.captures,
            n_incomplete=self.incomplete,
            n_frames=self.frames,
            n_found=self.found,
            seconds=time.monotonic() - self.started,
            dropped=self.dropped,
            n_complete_trials=proc.n_complete_trials,
            n_accepted=proc.n_accepted,
            n_discarded=proc.n_discarded,
            interrupted=interrupted,
            kept=kept,
        )
