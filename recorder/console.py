"""The operator's web console (``twopose-record new SESSION --ui``): the thesis' GUI
(section 5.2.4, Figure 17) in the browser, as one more front end of the one procedure.

The page (``console.html``, no build step) polls ``GET /api/state`` and sends the operator's
answers; the recording runs :func:`recorder.procedure.record` in a thread with a
:class:`WebDriver`, exactly as the terminal and plan modes do, so the file, the checks
and the crash safety are theirs: closing the tab loses nothing (reopening it shows the
running session), killing the server loses at most the capture in progress (``recover``
salvages the rest). The setup form is checked by the terminal's own questions
(:func:`recorder.interactive.ask_setup`, answered from the form); poses by its parser.

Routes (Starlette, served by uvicorn on 127.0.0.1 unless ``--host`` says otherwise):

=====================  ====================================================================
``GET /``              the page
``GET /api/state``     everything the page shows, as JSON (:meth:`ConsoleSession.snapshot`)
``POST /api/setup``    the setup form: ``method, units, focal, principal, ground_height,
                       truth1, truth2, keep_off_ground, operator``
``POST /api/pose``     ``x, y, z, rotation``: type the pose and capture it
``POST /api/decide``   ``decision``: ``accept``, ``redo``, ``undo`` or ``quit``
``POST /api/note``     ``text``: a note about the current trial (after a capture)
``GET /stream.mjpg``   the live camera with the detection drawn (MJPEG)
=====================  ====================================================================

A refused request answers 400 with ``{"error": message}`` and records nothing.
"""

from __future__ import annotations

import queue
import threading
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from typing_extensions import override

from recorder import stops
from recorder.capture import LiveSink
from recorder.driver import (
    Decision,
    Driver,
    LowDetectionError,
    Placement,
    ProcedureRefusedError,
    QuitRecording,
)
from recorder.procedure import Shortfall, detection_shortfall
from recorder.setup_rules import PoseTyping, form_fields
from recorder.summary import RecordingSummary
from twopose.bounds import shown
from twopose.format.entries import GroundTruth, Note, PoseEntry, TruthKind, TypedEntry
from twopose.format.reader import recover_command
from twopose.methods import Method, MethodSpec, spec_of
from twopose.units import Units
from twopose.values import Vec3

if TYPE_CHECKING:
    from recorder.capture import CaptureResult
    from recorder.setup_rules import Setup
    from recorder.sources import FrameSource, SourceInfo
    from recorder.trial_result import TrialResult
    from twopose.detect import Detection
    from twopose.guidance import Advice
    from twopose.rig.constants import RigConstants
    from twopose.scene3d import TrialScene
    from twopose.targets import BoardPlacement

__all__ = ["DECISIONS", "ConsoleSession", "WebDriver"]

#: The decision buttons (``POST /api/decide``) and what each tells the procedure.
DECISIONS = {
    "accept": Decision.ACCEPT,
    "accept_anyway": Decision.ACCEPT_ANYWAY,
    "redo": Decision.REDO,
    "undo": Decision.UNDO,
}


@dataclass(kw_only=True)
class _Frame:
    data: bytes  # JPEG as stored (or a preview's)
    detection: Detection | None
    seq: int


def _frame_numbers(index: int, det: Detection | None) -> dict[str, Any]:
    """One captured frame's numbers as the thesis' GUI showed them (section 5.2.4)."""
    from recorder.capture import FrameFeedback

    if det is None:
        return {"frame": index, "found": None}
    fb = FrameFeedback(
        index=index - 1,
        found=det.found,
        centroid_px=det.centroid_px,
        theta_deg=det.theta_deg,
        n_blobs=det.n_blobs,
        reason=det.reason,
        area_px=det.area_px, eccentricity=det.eccentricity,
    )  # fmt: skip
    return fb.to_json()


class ConsoleSession(LiveSink):
    """What the page shows and what it asks, shared by the server and the recording
    thread (every access under one lock). It is also the recorder's live sink
    (:class:`recorder.capture.LiveSink`): frames, status and trial results arrive here."""

    def __init__(self, out: Path, given: dict[str, Any] | None = None) -> None:
        self.out = out
        self.lock = threading.Condition()
        self.commands: queue.Queue[tuple[str, Any]] = queue.Queue()
        self.closing = threading.Event()  # the server is stopping (Ctrl-C, SIGTERM)
        self.phase = "setup"  # setup, recording, done, failed
        self.setup_fields = form_fields(given or {})
        #: A continuation's file, its last trial and the next (``new --continue``), or None.
        self.continuing: dict[str, Any] | None = (given or {}).get("continuing")
        #: What the recorder works out while no control is on (after a decision: the
        #: trial's result, the next pose to suggest), in words; "" when it waits or records.
        self.computing = ""
        self.method: Method | None = None  # set when the setup is accepted
        self.units: Units | None = None
        self.waiting = ""  # pose, decision, or "" (capturing, between steps)
        self.trial = self.pose = self.n_poses = 0
        self.poses: list[dict[str, Any]] = []  # this trial's typed poses so far
        self.pose_form: dict[str, Any] = {}  # what the pose form shows (after undo: retyped)
        self.capture = {"frame": 0, "n_frames": 0}
        self.frames: list[dict[str, Any]] = []  # the capture's per-frame numbers
        self.frames_of: dict[str, int] = {}  # {trial, pose} of the capture they belong to
        self.average: dict[str, Any] | None = None  # the capture's pose average
        self.shortfall = Shortfall.OK.value
        self.preview: dict[str, Any] | None = None  # the result if the capture is accepted
        self.message = "fill in the setup"
        if self.continuing is not None:
            c = self.continuing
            self.message = (
                f"Continuing {c['file']}; the next trial is {c['next_trial']}. Its setup is "
                "kept (fixed below): check the operator and the stop rule, then start"
            )
        self.level = "info"  # info, warning, error: how the page colours the message
        self.refusal: dict[str, Any] = {}  # {control, message, seq}: shown by that control
        self.live_error = ""
        self.notices: list[str] = []  # what the operator should know, that is no failure
        self.session_setup: dict[str, Any] = {}  # what is recorded: shown while recording
        self.notes: list[dict[str, Any]] = []  # the operator's notes: {trial, text}
        self.board: BoardPlacement | None = None  # a board session's board
        self.rig_readiness = ""  # a board session: why its poses cannot determine the rig
        self.last_capture = ""
        self.results: dict[int, dict[str, Any]] = {}
        #: the latest guidance: the next pose suggested, or the trial complete (issue 36)
        self.advice: dict[str, Any] | None = None
        self.topview: dict[str, Any] | None = None
        self.summary = ""
        self.latest: _Frame | None = None
        self.viewers = 0  # pages watching the live image (the preview runs only for them)
        self.preview_at = 0.0  # monotonic time of the last preview frame
        self._refusals = 0

    # -- the page's view
    def snapshot(self) -> dict[str, Any]:
        """Everything the page shows (NaN and infinity are left to the one JSON encoder)."""
        with self.lock:
            return {
                "phase": self.phase,
                "out": str(self.out),
                "method": self.method or "",
                "units": self.units or "",
                "setup_fields": self.setup_fields if self.phase == "setup" else [],
                "waiting": self.waiting,
                "computing": self.computing,
                "continuing": self.continuing,
                # What salvages the file if the recorder dies (the page says it then).
                "recover": recover_command(self.out),
                "trial": self.trial,
                "pose": self.pose,
                "n_poses": self.n_poses,
                "poses": list(self.poses),
                "pose_form": dict(self.pose_form),
                "capture": dict(self.capture),
                "frames": list(self.frames),
                "frames_of": dict(self.frames_of),
                "average": self.average,
                "shortfall": self.shortfall,
                # No preview of a result the operator cannot accept (nothing was found).
                "preview": None if self.shortfall == Shortfall.NONE_FOUND.value else self.preview,
                "message": self.message,
                "level": self.level,
                "refusal": dict(self.refusal),
                "live_error": self.live_error,
                "notices": list(self.notices),
                "setup": dict(self.session_setup),
                "notes": list(self.notes),
                "rig_readiness": self.rig_readiness,
                "last_capture": self.last_capture,
                "results": [self.results[t] for t in sorted(self.results)],
                "advice": self.advice,
                "topview": self.topview,
                "summary": self.summary,
                "frame_seq": self.latest.seq if self.latest else 0,
            }

    def update(self, **fields: Any) -> None:
        with self.lock:
            for name, value in fields.items():
                setattr(self, name, value)
            self.lock.notify_all()

    def method_spec(self) -> MethodSpec | None:
        """The session's method's spec (None before the setup is accepted)."""
        return None if self.method is None else spec_of(self.method)

    def begin(self, setup: Setup, rig: RigConstants | None) -> None:
        """The setup is accepted: recording starts, and what it records stays in view."""
        k = setup.intrinsics
        line: dict[str, Any] = {
            "method": setup.method.value,
            "units": setup.units.value,
            "camera": f"f {shown(k.fx)} px, principal point ({shown(k.cx)}, {shown(k.cy)}) px, "
            f"{k.width}x{k.height}",
            "truth": [_vec(p) for p in setup.ground_truth],
            "ground_height": setup.ground_height,
            "operator": setup.operator,
            "rig": "" if rig is None else "a calibrated rig corrects the live result",
            "stop_rule": "" if setup.board is not None else stop_rule(setup),
        }
        if self.continuing is not None:
            c = self.continuing
            line["continues"] = f"{c['file']} after trial {c['after_trial']}"
        if setup.board is not None:
            b = setup.board
            line["board"] = (
                f"{b.inner_corners[0]}x{b.inner_corners[1]} inner corners, squares of "
                f"{shown(b.square)} {setup.units.value}, first corner at "
                f"({', '.join(shown(v) for v in b.first_corner)})"
            )
        self.update(
            method=setup.method,
            units=setup.units,
            phase="recording",
            session_setup=line,
            board=setup.board,
        )

    def refuse(self, control: str, message: str) -> None:
        """A refusal the page shows next to ``control`` (a decision button, a form)."""
        with self.lock:
            self._refusals += 1
            self.refusal = {"control": control, "message": message, "seq": self._refusals}
            self.lock.notify_all()

    # -- the recorder's live sink
    @override
    def frame(
        self,
        camera_id: str,
        data: bytes,
        image_format: str,
        log_time_ns: int,
        detection: Detection | None,
        label: str,
    ) -> None:
        with self.lock:
            seq = self.latest.seq + 1 if self.latest else 1
            self.latest = _Frame(data=data, detection=detection, seq=seq)
            if label:  # a captured frame (previews have no label): its numbers, live
                self.frames.append(_frame_numbers(len(self.frames) + 1, detection))
            self.lock.notify_all()

    @override
    def status(
        self,
        log_time_ns: int,
        *,
        trial: int,
        pose: int,
        frame: int,
        n_frames: int,
        message: str,
        found: bool | None = None,
    ) -> None:
        self.update(capture={"frame": frame, "n_frames": n_frames}, message=message, level="info")

    @override
    def trial_result(self, result: TrialResult, scene: TrialScene | None, log_time_ns: int) -> None:
        from twopose.topview import top_view

        with self.lock:
            self.results[result.trial] = result.to_json()
            self.topview = None if scene is None else top_view(scene).to_json()
            self.lock.notify_all()

    def withdraw(self, trial: int) -> None:
        """The trial's result is gone (an undo left it fewer than two poses)."""
        with self.lock:
            self.results.pop(trial, None)
            if self.topview is not None and self.topview.get("trial") == trial:
                self.topview = None
            self.lock.notify_all()

    def next_frame(self, after: int, timeout_s: float) -> _Frame | None:
        """The newest frame after sequence number ``after`` (None: none came in time)."""
        with self.lock:
            self.lock.wait_for(
                lambda: self.latest is not None and self.latest.seq > after, timeout=timeout_s
            )
            latest = self.latest
            return latest if latest is not None and latest.seq > after else None


def stop_rule(setup: Setup) -> str:
    """The stop rule in force, as the page's setup line says it."""
    if setup.target95 is None:
        return "none (suggestions only)"
    within = f"{shown(setup.target95)} {setup.units}"
    return f"a trial is complete once its 95% region is within {within}"


def _vec(v: Vec3) -> list[float]:
    return [float(x) for x in v]


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
        self.session.update(
            trial=trial,
            pose=1,
            poses=[],
            pose_form={},
            advice=None,
            computing="",
            message=f"{said}trial {trial}: type pose 1, then capture (or quit to finish)",
            level="info",
        )
        try:
            self._pending = self._wait("pose")
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

    def _wait(self, what: str) -> tuple[str, Any]:
        """The page's next command for ``what`` (pose or decision); quit ends it all."""
        self.session.update(waiting=what, computing="")
        while True:
            stops.check()  # the server is stopping (Ctrl-C, SIGTERM, SIGHUP)
            try:
                command = self.session.commands.get(timeout=0.05)
            except queue.Empty:
                if self.preview is not None and self.source is not None:
                    self.preview(self.source, self.session)
                continue
            if command[0] == "quit":
                self.session.update(waiting="")
                raise QuitRecording
            if command[0] == "interrupt":  # the server stops: as Ctrl-C at a terminal
                self.session.update(waiting="")
                raise KeyboardInterrupt
            if command[0] in _EXPECTED[what]:
                self.session.update(waiting="")
                return command

    def _show_poses(self, current: int, state: str) -> None:
        """This trial's poses: the accepted ones, then the one being typed or decided."""
        listed = sorted(p for p in self._typed if p in self._accepted and p < current)
        rows = [self._pose_row(p, "accepted") for p in listed]
        if current in self._typed and state:
            rows.append(self._pose_row(current, state))
        self.session.update(poses=rows)

    def _pose_row(self, pose: int, state: str) -> dict[str, Any]:
        t, r = self._typed[pose]
        return {"pose": pose, "t": _vec(t), "r_deg": _vec(r), "state": state}

    def place(self, trial: int, pose: int) -> Placement:
        # The form shows this pose's last typed values when it is retyped (after redo or
        # undo); a new pose starts empty, never with another pose's values.
        typed = self._typed.get(pose)
        form = {} if typed is None else {"t": _vec(typed[0]), "r_deg": _vec(typed[1])}
        self._accepted.discard(pose)
        self._show_poses(pose, "")
        n_poses = self.typing.poses_per_trial
        self.session.update(
            pose=pose,
            pose_form=form,
            computing="",
            message=f"trial {trial}: type pose {pose} of {n_poses}, then capture",
            level="info",
        )
        command, self._pending = self._pending or self._wait("pose"), None
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
        state = result.state
        shortfall = detection_shortfall(result)
        message, level = f"trial {trial} pose {pose}: accept, redo, undo or quit", "info"
        if not result.complete:
            message, level = f"trial {trial} pose {pose}: the capture is incomplete: redo", "error"
        elif shortfall is Shortfall.NONE_FOUND:
            message = f"trial {trial} pose {pose}: {result.sought} was not found in any frame: redo"
            level = "error"
        elif shortfall is Shortfall.FEW_FOUND:
            message = (
                f"trial {trial} pose {pose}: {result.sought} was found in only "
                f"{result.n_found} of {len(result.feedback)} frames: redo, or accept anyway"
            )
            level = "warning"
        average = result.pose_average()
        overhead = (
            sum(result.overhead_s) / len(result.overhead_s) * self.fps if result.overhead_s else 0.0
        )
        self._show_poses(pose, "awaiting decision")
        found = f"{result.n_found} with {result.sought} found, " if result.feedback else ""
        self.session.update(
            last_capture=f"{result.n_frames} frames, {found}{state}, {result.dropped} dropped; "
            f"recorder overhead {100 * overhead:.0f}% of the frame interval",
            frames=[f.to_json() for f in result.feedback],
            average=None if average is None else _average(average),
            shortfall=shortfall.value,
            message=message,
            level=level,
        )

    def preview_result(self, result: TrialResult) -> None:
        self.session.update(preview=result.to_json())

    def live_failed(self, message: str) -> None:
        self.session.update(live_error=message)

    def board_progress(self, seen_from: Sequence[Vec3], problem: str) -> None:
        from twopose.topview import board_top_view

        board = self.session.board
        view = None if board is None else board_top_view(board, seen_from).to_json()
        self.session.update(rig_readiness=problem, topview=view)

    def notice(self, message: str) -> None:
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
        self._computing(trial, pose, Decision(decision))
        return Decision(decision)

    @override
    def computing(self, what: str) -> None:
        """The procedure computes the next suggestion: the page says so (the decision said
        it already; this keeps it said until the form comes back)."""
        if not self.session.computing:
            self.session.update(computing=f"trial {self.session.trial}: {what.rstrip('….')}")

    def _computing(self, trial: int, pose: int, decision: Decision) -> None:
        """Between a decision and the next step the recorder works (the trial's result,
        the next pose to suggest: seconds on fine grid paper) with every control off: the
        page says so, and lists the pose as decided, not as awaiting a decision."""
        done = {Decision.REDO: "to be captured again", Decision.UNDO: "undone"}
        what = (
            "checking what the poses so far say of the rig"
            if self.session.board is not None
            else "computing the trial's result and the next pose to suggest"
        )
        self._show_poses(pose + 1 if pose in self._accepted else pose, "")
        self.session.update(
            computing=f"trial {trial} pose {pose} {done.get(decision, 'accepted')}: {what}; "
            "the form comes back when it is done"
        )

    def note(self, trial: int) -> Note:
        with self.session.lock:
            self.session.notes.append({"trial": trial, "text": self._note})
        self.session.update(message=f"note added to trial {trial}", level="info")
        return Note(text=self._note, trial=trial)

    def refused(self, error: ProcedureRefusedError) -> None:
        self._accepted.discard(self.session.pose)
        self._show_poses(self.session.pose, "awaiting decision")
        control = "accept" if isinstance(error, LowDetectionError) else self._control
        self.session.refuse(control or "decision", str(error))

    def advice(self, trial: int, advice: Advice) -> bool:
        s = advice.suggestion
        self.session.update(
            advice={
                "trial": trial,
                "text": advice.text,
                "complete": advice.complete,
                "region95": advice.region95,
                "suggestion": None if s is None else s.to_json(),
            }
        )
        return advice.complete

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


_EXPECTED = {"pose": {"pose"}, "decision": {"decision", "note"}}
