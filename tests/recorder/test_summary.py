"""recorder.procedure.summary directly: the tally counts each capture window once, by its last
decision (as the file holds them), and the one summary line says what the file holds, how
it ended, and that nothing was written when nothing was."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Any

from recorder.procedure.capture import CaptureResult, FrameFeedback
from recorder.procedure.summary import RecordingSummary, Tally


@dataclass
class _Counts:
    trial: int = 2
    n_complete_trials: int = 1


def _feedback(found: list[bool]) -> tuple[FrameFeedback, ...]:
    return tuple(
        FrameFeedback(
            index=i, found=f, centroid_px=(1.0, 2.0), theta_deg=0.0, n_blobs=int(f), reason=""
        )
        for i, f in enumerate(found)
    )


def test_the_tally_counts_every_window_once_by_its_last_decision() -> None:
    tally = Tally()
    tally.add(
        CaptureResult(
            n_frames=5, complete=True, reason="", feedback=_feedback([True] * 5), capture=1
        )
    )
    tally.add(
        CaptureResult(
            n_frames=3, complete=False, reason="the camera stopped", dropped=2,
            feedback=_feedback([True, False, False]), capture=2,
        )
    )  # fmt: skip
    tally.add(CaptureResult(n_frames=5, complete=True, reason="", capture=3))  # no detection
    tally.decided(1, "accept")
    tally.decided(2, "discard")
    tally.decided(3, "accept")
    tally.decided(1, "discard")  # undone by a later capture: its last decision counts
    tally.decided(4, "discard")  # a typed pose the stop left without a window: no capture
    summary = tally.summary(Path("s.mcap"), _Counts(), interrupted=False, kept=True)
    assert (summary.n_captures, summary.n_incomplete, summary.n_frames) == (3, 1, 13)
    assert (summary.n_found, summary.dropped) == (6, 2)
    assert (summary.n_accepted, summary.n_discarded) == (1, 2)
    assert summary.n_accepted + summary.n_discarded == summary.n_captures
    assert summary.seconds >= 0


def test_the_line_in_words_and_its_endings() -> None:
    summary = RecordingSummary(
        path=Path("s.mcap"), n_trials=1, n_captures=2, n_incomplete=0, n_frames=10, n_found=9,
        seconds=12.34, dropped=1, n_complete_trials=1, n_accepted=2, n_discarded=0,
    )  # fmt: skip
    assert summary.line() == (
        "wrote s.mcap: 1 trial (1 complete), 2 captures (2 accepted, 0 discarded; "
        "0 incomplete), 10 frames (9 detected, 1 dropped) in 12.3 s"
    )
    stopped = RecordingSummary(**{**summary.__dict__, "interrupted": True})
    assert stopped.line().endswith(" (interrupted: the file is closed and valid)")
    empty = RecordingSummary(**{**summary.__dict__, "kept": False})
    assert empty.line() == "nothing was recorded: no session file written at s.mcap"


def test_the_summary_line_counts_in_words() -> None:
    counts: dict[str, Any] = {"n_incomplete": 0, "n_frames": 1, "n_found": 1, "seconds": 2.0}
    one = RecordingSummary(path=Path("s.mcap"), n_trials=1, n_captures=1, n_accepted=1, **counts)
    assert "1 trial (0 complete), 1 capture (1 accepted" in one.line()
    assert "1 frame (1 detected" in one.line()
    two = RecordingSummary(
        path=Path("s.mcap"), n_trials=2, n_captures=3, n_incomplete=1, n_frames=6, n_found=5,
        seconds=2.0,
    )  # fmt: skip
    assert "2 trials" in two.line()
    assert "3 captures" in two.line()
