"""The web console's driver: the page decides what the recording does.

:class:`WebDriver` is the :class:`recorder.procedure.driver.Driver` the console's recording thread
runs. It waits for the operator's pose form and buttons through
:class:`recorder.console.state.ConsoleSession`, shows the camera live while it waits, and says
each capture's and trial's result to the page.
"""

from __future__ import annotations

import threading
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import TYPE_CHECKING, Any

from typing_extensions import override

from recorder.console.state import ANSWERS, ConsoleSession, vec_json
from recorder.procedure import stops
from recorder.procedure.driver import (
    Decision,
    Driver,
    LowDetectionError,
    Placement,
    ProcedureRefusedError,
    QuitRecording,
)
from recorder.procedure.machine import Shortfall, detection_shortfall
from recorder.procedure.summary import RecordingSummary
from recorder.setup.rules import PoseTyping
from twopose.errors import TwoposeError
from twopose.format.entries import GroundTruth, Note, PoseEntry, TruthKind, TypedEntry
from twopose.values.checks import Vec3
from twopose.values.units import Units

if TYPE_CHECKING:
    from recorder.live.result import MappedAdvice
    from recorder.live.trial_result import TrialResult
    from recorder.procedure.capture import CaptureResult
    from recorder.sources.registry import FrameSource, SourceInfo
    from twopose.guidance.advice import Advice


__all__ = ["WebDriver", "said_ended", "said_failed"]


class WebDriver(Driver):
    """The page decides: the pose form captures, the buttons decide, quit ends. While it
    waits for the operator it shows the camera live (preview frames, not recorded)."""

    def __init__(
        self,
        session: ConsoleSession,
        source: FrameSource | None,
        camera_id: str,
        ground_truth: tuple[Vec3, ...],
        typing: PoseTyping,
        preview: Callable[[FrameSource, ConsoleSession], None] | None = None,
    ) -> None:
        self.session, self.source, self.camera_id = session, source, camera_id
        self.ground_truth = ground_truth
        self.typing = typing
        self.poses_per_trial = typing.poses_per_trial  # --poses (d18a7fc had lost it: 2 always)
        self.preview = preview
        self._note = ""
        self._pending: tuple[str, Any] | None = None  # a pose typed before its trial began
        self._typed: dict[int, tuple[Vec3, Vec3]] = {}  # this trial: pose -> last typed
        self._accepted: set[int] = set()  # this trial's accepted poses
        self._control = ""  # the decision button last pressed (where a refusal shows)
        self._asking = ""  # the status asking for the capture's decision
        self.fps = 30.0

    def start(self, source: SourceInfo, path: Path) -> None:
        self.fps = source.fps
        self.session.update(phase="recording", message=f"recording {path}", level="info")

    def next_trial(self, trial: int) -> bool:
        """The first trial begins at once; another when its first pose is typed (quit
        instead ends the session, with no empty trial left in the file)."""
        if trial == self.first_trial:
            return True
        self._typed, self._accepted = {}, set()
        # How the last trial ended (the stop rule, or its most poses) stays said until the
        # next trial's first pose: its advice goes with it.
        ended = self.session.advice
        said = f"trial {ended['trial']}: {ended['text']}. " if ended and ended["complete"] else ""
        try:
            self._pending = self._wait(
                "pose",
                trial=trial,
                pose=1,
                poses=[],
                pose_form={},
                advice=None,
                message=f"{said}trial {trial}: type pose 1, then capture (or quit to finish)",
                level="info",
            )
        except QuitRecording:
            return False
        return True

    def trial_entries(self, trial: int) -> tuple[TypedEntry, ...]:
        self.session.update(trial=trial, n_poses=self.typing.poses_per_trial)
        spec = self.session.method_spec()
        kind: TruthKind | None = spec.truth_kind if spec is not None else None
        if not self.ground_truth or kind is None:
            return ()
        return (GroundTruth(trial=trial, kind=kind, points_grid=self.ground_truth),)

    def _wait(self, what: str, **shown: Any) -> tuple[str, Any]:
        """The page's answer to ``what`` (pose or decision), offered to the page with
        ``shown`` (the status asking for it) in one update; an answer given before (while
        the recorder still worked) is taken first; quit ends it all."""
        self.session.offer(what, **shown)
        while True:
            stops.check()  # the server is stopping (Ctrl-C, SIGTERM, SIGHUP)
            answer = self.session.answer(timeout_s=0.05)
            if answer is None:
                if self.preview is not None and self.source is not None:
                    self.preview(self.source, self.session)
                continue
            if answer[0] == "quit":
                raise QuitRecording
            # The session takes only what it offered (ConsoleSession.take).
            assert answer[0] in ANSWERS[what], (what, answer)
            return answer

    def _show_poses(self, current: int, state: str) -> None:
        """This trial's poses: the accepted ones, then the one being typed or decided."""
        listed = sorted(p for p in self._typed if p in self._accepted and p < current)
        rows = [self._pose_row(p, "accepted") for p in listed]
        if current in self._typed and state:
            rows.append(self._pose_row(current, state))
        self.session.update(poses=rows)

    def _pose_row(self, pose: int, state: str) -> dict[str, Any]:
        t, r = self._typed[pose]
        return {"pose": pose, "t": vec_json(t), "r_deg": vec_json(r), "state": state}

    def place(self, trial: int, pose: int) -> Placement:
        # The form shows this pose's last typed values when it is retyped (after redo or
        # undo); a new pose starts empty, never with another pose's values.
        typed = self._typed.get(pose)
        form = {} if typed is None else {"t": vec_json(typed[0]), "r_deg": vec_json(typed[1])}
        self._accepted.discard(pose)
        self._show_poses(pose, "")
        n_poses = self.typing.poses_per_trial
        command, self._pending = self._pending, None
        if command is None:  # else typed already, as the trial began
            command = self._wait(
                "pose",
                pose=pose,
                pose_form=form,
                message=f"trial {trial}: type pose {pose} of {n_poses}, then capture",
                level="info",
            )
        _, (t, r) = command
        self._typed[pose] = (t, r)
        self._show_poses(pose, "capturing")
        self.session.update(
            message=f"trial {trial} pose {pose}: capturing",
            frames=[],
            frames_of={"trial": trial, "pose": pose},
            average=None,
            preview=None,
            shortfall=Shortfall.OK.value,
            refusal={},
        )
        entry = PoseEntry(
            trial=trial,
            pose=pose,
            camera_id=self.camera_id,
            t_grid=t,
            r_deg=r,
            translation_resolution=self.typing.translation_sigma(self.session.units or Units.IN),
            rotation_resolution_deg=self.typing.rotation_resolution_deg,
        )
        return Placement(entry=entry)

    def captured(self, trial: int, pose: int, result: CaptureResult) -> None:
        """The capture's numbers, and its decision offered at once, with the status that
        asks for it: a decision given while the preview result is computed is taken, and
        read once it is (:meth:`decide`)."""
        state = result.state
        shortfall = detection_shortfall(result)
        why, offers, level = _offers(result, shortfall)
        self._asking = f"trial {trial} pose {pose}: {why}{_listed([*offers, 'quit'])}"
        average = result.pose_average()
        overhead = (
            sum(result.overhead_s) / len(result.overhead_s) * self.fps if result.overhead_s else 0.0
        )
        self._show_poses(pose, "awaiting decision")
        found = f"{result.n_found} with {result.sought} found, " if result.feedback else ""
        self.session.offer(
            "decision",
            anew=True,
            last_capture=f"{result.n_frames} frames, {found}{state}, {result.dropped} dropped; "
            f"recorder overhead {100 * overhead:.0f}% of the frame interval",
            frames=[f.to_json() for f in result.feedback],
            average=None if average is None else _average(average),
            shortfall=shortfall.value,
            offers=offers,
            message=self._asking,
            level=level,
        )

    def preview_result(self, result: TrialResult) -> None:
        self.session.update(preview=result.to_json())

    def live_failed(self, message: str) -> None:
        self.session.update(live_error=message)

    def board_progress(self, seen_from: Sequence[Vec3], problem: str) -> None:
        from twopose.methods.topview import board_top_view

        board = self.session.board
        view = None if board is None else board_top_view(board, seen_from).to_json()
        self.session.update(rig_readiness=problem, topview=view)

    def notice(self, message: str) -> None:
        import sys

        # Also at the terminal the console was started from, as the other drivers say it
        # (the placing sigma the regions assume: its log keeps it).
        print(f"note: {message}", file=sys.stderr, flush=True)
        with self.session.lock:
            self.session.notices.append(message)
            self.session.lock.notify_all()

    @override
    def decide(self, trial: int, pose: int, result: CaptureResult) -> Decision:
        kind, value = self._wait("decision")
        if kind == "note":
            self._note = str(value)
            return Decision.NOTE
        control, decision = value
        self._control = control
        if decision in (Decision.ACCEPT, Decision.ACCEPT_ANYWAY):
            self._accepted.add(pose)
        elif decision is Decision.UNDO and pose > 1:
            self._accepted.discard(pose - 1)
        return Decision(decision)

    @override
    def computing(self, what: str) -> None:
        """The procedure computes the next suggestion: the page says so (the decision said
        it already; this keeps it said until the form comes back)."""
        if not self.session.computing:
            self.session.update(computing=f"trial {self.session.trial}: {what.rstrip('….')}")

    def note(self, trial: int) -> Note:
        """The note, listed; the status still asks for the capture's decision (its buttons
        stay on)."""
        with self.session.lock:
            self.session.notes.append({"trial": trial, "text": self._note})
            asking = self._asking
        self.session.update(message=f"note added to trial {trial}. {asking}", level="info")
        return Note(text=self._note, trial=trial)

    def refused(self, error: ProcedureRefusedError) -> None:
        self._accepted.discard(self.session.pose)
        self._show_poses(self.session.pose, "awaiting decision")
        control = "accept" if isinstance(error, LowDetectionError) else self._control
        self.session.refuse(control or "decision", str(error))

    def advice(self, trial: int, advice: Advice) -> bool:
        from recorder.live.result import MappedAdvice

        s = advice.suggestion
        shown = {
            "trial": trial,
            "text": advice.text,
            "complete": advice.complete,
            "region95": advice.region95,
            "suggestion": None if s is None else s.to_json(),
            "map": None,
        }
        self.session.update(advice=shown)
        if isinstance(advice, MappedAdvice) and not advice.complete:
            # The map of every reachable pose's region (drawn under the top view) follows
            # the suggestion: the form comes back without waiting for it.
            threading.Thread(
                target=self._map, args=(shown, advice), name="region-map", daemon=True
            ).start()
        return advice.complete

    def _map(self, shown: dict[str, Any], advice: MappedAdvice) -> None:
        """The advice's map, to the page if its advice is still the one shown."""
        try:
            region_map = advice.region_map
        except Exception as error:  # a map that fails leaves the advice as it is
            self.session.update(live_error=f"the map of the next poses failed: {error}")
            return
        drawn = None if region_map is None else region_map.to_json()
        with self.session.lock:
            if self.session.advice is shown:
                self.session.advice = {**shown, "map": drawn}
                self.session.lock.notify_all()

    def trial_result(self, result: TrialResult) -> None:
        level = "warning" if result.warning or result.status != "ok" else "info"
        self.session.update(message=result.text(), level=level, preview=None)

    def result_withdrawn(self, trial: int) -> None:
        self.session.withdraw(trial)

    def advice_withdrawn(self, trial: int) -> None:  # noqa: ARG002 - the page shows one trial
        self.session.update(advice=None)

    def finish(self, summary: RecordingSummary) -> None:
        self.session.update(
            phase="done",
            waiting="",
            computing="",
            poses=[],
            summary=summary.line(),
            message="the session is finished: " + summary.line(),
            level="info",
        )


def _average(m: Any) -> dict[str, Any]:
    """The pose's combined measurement, as the page shows it."""
    return {
        "found": m.found,
        "n_used": m.n_used,
        "n_frames": m.n_frames,
        "centroid_px": list(m.centroid_px),
        "theta_deg": m.theta_deg,
        "centroid_std_px": list(m.centroid_std_px),
    }


def _offers(result: CaptureResult, shortfall: Shortfall) -> tuple[str, list[str], str]:
    """What the status says of a capture, the decisions it offers (the buttons on, the
    server takes no other), and the status' level."""
    if not result.complete:
        return "the capture is incomplete: ", ["redo", "undo"], "error"
    if shortfall is Shortfall.NONE_FOUND:
        return f"{result.sought} was not found in any frame: ", ["redo", "undo"], "error"
    if shortfall is Shortfall.FEW_FOUND:
        found = f"{result.n_found} of {len(result.feedback)} frames"
        why = f"{result.sought} was found in only {found}: "
        return why, ["redo", "accept_anyway", "undo"], "warning"
    return "", ["accept", "redo", "undo"], "info"


def _listed(choices: list[str]) -> str:
    """``accept, redo, undo or quit``: the choices in words."""
    words = [c.replace("_", " ") for c in choices]
    return f"{', '.join(words[:-1])} or {words[-1]}"


def said_ended(summary_line: str, *, stopped: bool) -> None:
    """A console recording thread's end: its summary printed once (and, unless the console
    is stopping, how to stop it). The one-camera and the pair recording both end so."""
    hint = "" if stopped else "\n(the console shows it; Ctrl-C stops the console)"
    print(summary_line + hint, flush=True)


def said_failed(session: ConsoleSession, err: Exception) -> None:
    """A console recording thread's failure said on the page, never as a thread's
    traceback: a TwoposeError in its own words, anything else named by its type."""
    message = str(err) if isinstance(err, TwoposeError) else f"{type(err).__name__}: {err}"
    session.update(phase="failed", waiting="", message=message)
