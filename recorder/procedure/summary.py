"""What a recording holds and how it ended: the one summary line every recording path
prints (terminal, plan, browser), counted from what the procedure wrote to the file."""

from __future__ import annotations

import time
from dataclasses import dataclass, field
from pathlib import Path
from typing import Protocol

from recorder.procedure.capture import CaptureResult

__all__ = ["RecordingSummary", "Tally"]


class TrialCounts(Protocol):
    """The trials the procedure counted (:class:`recorder.procedure.machine.Procedure`)."""

    trial: int
    n_complete_trials: int


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
    """What the procedure wrote, entry for entry: every capture window (with how its
    capture went) and each capture's last decision. The summary counts them as
    ``twopose-analyze info`` reads the file (:func:`twopose.format.trials.describe_session`):
    a capture is a window in the file, complete or not (one a stop cut short is counted,
    incomplete, with its frames); it is accepted if its last decision is ``accept`` and
    discarded if it is ``discard``. The procedure decides every capture it wrote before it
    closes, so ``accepted + discarded == captures``."""

    started: float = field(default_factory=time.monotonic)
    after_trial: int = 0  # a continuation's trials are numbered after this: not its own
    windows: list[CaptureResult] = field(default_factory=list)  # in the order written
    verdicts: dict[int, str] = field(default_factory=dict)  # capture number -> last decision

    def add(self, result: CaptureResult) -> None:
        """A capture window was written (complete, or cut short)."""
        self.windows.append(result)

    def decided(self, capture: int, verdict: str) -> None:
        """A decision on capture ``capture`` was written (a later one overrides it)."""
        self.verdicts[capture] = verdict

    def _final(self, verdict: str) -> int:
        return sum(
            r.capture is not None and self.verdicts.get(r.capture) == verdict for r in self.windows
        )

    @property
    def n_accepted(self) -> int:
        return self._final("accept")

    @property
    def n_discarded(self) -> int:
        return self._final("discard")

    def summary(
        self, path: Path, proc: TrialCounts, *, interrupted: bool, kept: bool
    ) -> RecordingSummary:
        """The summary of a recording whose procedure is ``proc``."""
        return RecordingSummary(
            path=path,
            n_trials=max(0, proc.trial - self.after_trial),  # this file's trials
            n_captures=len(self.windows),
            n_incomplete=sum(not r.complete for r in self.windows),
            n_frames=sum(r.n_frames for r in self.windows),
            n_found=sum(r.n_found for r in self.windows),
            seconds=time.monotonic() - self.started,
            dropped=sum(r.dropped for r in self.windows),
            n_complete_trials=proc.n_complete_trials,
            n_accepted=self.n_accepted,
            n_discarded=self.n_discarded,
            interrupted=interrupted,
            kept=kept,
        )
