"""The operator's web console (``twopose-record new SESSION --ui``): the thesis' GUI
(section 5.2.4, Figure 17) in the browser, as one more front end of the one procedure.

The page (``index.html``, no build step) polls ``GET /api/state`` and sends the operator's
answers; the recording runs :func:`recorder.procedure.recording.record` in a thread with a
:class:`recorder.console.driver.WebDriver`, exactly as the terminal and plan modes do, so
the file, the checks and the crash safety are theirs: closing the tab loses nothing
(reopening it shows the running session), killing the server loses at most the capture in
progress (``recover`` salvages the rest). The setup form is checked by the terminal's own
questions (:func:`recorder.procedure.terminal.ask_setup`, answered from the form); poses by its
parser.

Routes (Starlette, served by uvicorn on 127.0.0.1 unless ``--host`` says otherwise):

=====================  ====================================================================
``GET /``              the page
``GET /api/state``     everything the page shows, as JSON (:meth:`ConsoleSession.snapshot`)
``POST /api/setup``    the setup form: ``method, units, focal, principal``, the method's
                       plane's offset under its key (``ground_height``), ``truth1,
                       truth2, keep_off_ground, operator``
``POST /api/pose``     ``x, y, z, rotation``: type the pose and capture it
``POST /api/decide``   ``decision``: ``accept``, ``redo``, ``undo`` or ``quit``
``POST /api/note``     ``text``: a note about the current trial (after a capture)
``POST /api/stream``   a pair's stream trial: ``action`` start, touch (``x, y, z``), end,
                       stop (:mod:`recorder.console.stream_driver`)
``GET /stream.mjpg``   the live camera with the detection drawn (MJPEG)
``GET /api/pointing``  the live pointing panel's pairs, pushed (Server-Sent Events:
                       :mod:`recorder.console.pointing_route`)
``GET /api/clock``     the server's monotonic clock (the page's latency, measured)
=====================  ====================================================================

A refused request answers 400 with ``{"error": message}`` and records nothing.

What the page shows and what the server takes are one state (:class:`ConsoleSession`):
the recorder *offers* a step (``waiting``: a pose, or a decision among ``offers``) in the
same update as the status that asks for it, and an answer is *taken* for the recorder
under the same lock that checks it is offered (:meth:`ConsoleSession.take`), closing the
offer at once. So a button is on exactly while the status asks for it, an answer given
while the recorder still works (the capture's preview result) waits for it, in order, and
anything else is refused in words: never ignored, never applied to a later step.
"""

from __future__ import annotations

import threading
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

from typing_extensions import override

from recorder.procedure.capture import LiveSink
from recorder.procedure.driver import (
    Decision,
)
from recorder.procedure.machine import Shortfall
from recorder.setup.form import form_fields
from twopose.format.reader import recover_command
from twopose.methods.specs import Method, MethodPage, MethodSpec, spec_of
from twopose.values.bounds import shown
from twopose.values.checks import Vec3
from twopose.values.units import Units

if TYPE_CHECKING:
    from collections.abc import Callable

    from recorder.live.trial_result import TrialResult
    from recorder.setup.rules import Setup
    from twopose.detect.detection import Detection
    from twopose.display.scene import TrialScene
    from twopose.methods.targets import BoardPlacement
    from twopose.rig.constants import RigConstants

__all__ = ["ANSWERS", "DECISIONS", "ConsoleSession", "vec_json"]

#: The decision buttons (``POST /api/decide``) and what each tells the procedure.
DECISIONS = {
    "accept": Decision.ACCEPT,
    "accept_anyway": Decision.ACCEPT_ANYWAY,
    "redo": Decision.REDO,
    "undo": Decision.UNDO,
}

#: What the recorder may offer the page (``waiting``) and the answers each takes
#: (``quit`` is taken at any step of a recording). A pair's session (``new --pair --ui``)
#: offers stream trials instead of poses: ``trial`` (start the next trial's stream) and,
#: while it streams, ``streaming`` (a touch at a grid point, now; end the trial).
ANSWERS = {
    "pose": ("pose",),
    "decision": ("decision", "note"),
    "trial": ("start",),
    "streaming": ("touch", "end"),
}

#: How the page and the computing words say a decision taken.
_DONE = {"redo": "to be captured again", "undo": "undone"}


@dataclass(kw_only=True)
class _Frame:
    data: bytes  # JPEG as stored (or a preview's)
    detection: Detection | None
    seq: int


def _frame_numbers(index: int, det: Detection | None) -> dict[str, Any]:
    """One captured frame's numbers as the thesis' GUI showed them (section 5.2.4)."""
    from recorder.procedure.capture import FrameFeedback

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
    (:class:`recorder.procedure.capture.LiveSink`): frames, status and trial results arrive here."""

    def __init__(self, out: Path, given: dict[str, Any] | None = None) -> None:
        self.out = out
        self.lock = threading.Condition()  # its lock is reentrant: update() under it
        #: The answers taken for the recorder, in the order given (:meth:`take`).
        self._answers: deque[tuple[str, Any]] = deque()
        self.quitting = False  # quit was taken: nothing more is offered
        self._interrupted = False  # the server stops: the recording ends as at Ctrl-C
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
        self.waiting = ""  # what is offered: pose, decision, or "" (capturing, between steps)
        #: The decisions the status offers for the capture awaiting one (the buttons on).
        self.offers: list[str] = []
        self.offer_id = 0  # which capture's decision is (or was last) offered: 1, 2, ...
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
            if c.get("guidance"):  # the guidance settings it takes from the session
                self.message += f". {c['guidance'][0].upper()}{c['guidance'][1:]}"
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
        #: A pair's session: its stream trial as it goes (trial, touches, frames, the
        #: clock offset, the trials ended), :mod:`recorder.console.stream_driver`'s; None:
        #: one camera's session.
        self.stream: dict[str, Any] | None = None
        #: A pair's session: why a touch's grid point cannot be touched ("": it can).
        self.touch_refusal: Callable[[Vec3], str] = lambda _point: ""
        self._refusals = 0

    # -- the page's view
    def snapshot(self) -> dict[str, Any]:
        """Everything the page shows (NaN and infinity are left to the one JSON encoder)."""
        with self.lock:
            return {
                "phase": self.phase,
                "out": str(self.out),
                "method": self.method or "",
                # What the page shows for the method: panels, headings, words (before the
                # setup is accepted, a measuring method's).
                "page": (spec_of(self.method).page if self.method else MethodPage()).to_json(),
                "units": self.units or "",
                "setup_fields": self.setup_fields if self.phase == "setup" else [],
                "waiting": self.waiting,
                "offers": list(self.offers),
                "offer": self.offer_id,
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
                "stream": None if self.stream is None else dict(self.stream),
            }

    def update(self, **fields: Any) -> None:
        with self.lock:
            for name, value in fields.items():
                setattr(self, name, value)
            self.lock.notify_all()

    # -- the one state: what the recorder offers, what the page answers
    def offer(self, what: str, *, anew: bool = False, **shown: Any) -> None:
        """The recorder takes ``what`` (:data:`ANSWERS`) from now on, and the page shows
        ``shown`` (the status asking for it, the decisions offered) in the same update.
        Nothing is offered, nor asked for by the status, while an answer taken waits to be
        read (it is the answer) or once quit is taken. ``anew``: a new capture's decision
        (its own ``offer`` number; what was refused before is no longer said)."""
        with self.lock:
            if self._answers or self.quitting:
                # The status keeps saying what the recorder does with the answer it took
                # (quit: the session is being closed): it asks for nothing now.
                asking = ("message", "level", "offers")
                self.update(**{k: v for k, v in shown.items() if k not in asking})
                return
            if anew:  # a note, or the procedure's refusal, keeps the capture's offer
                self.offer_id += 1
                self.refusal = {}  # said of a step before this one: no longer true
            self.update(waiting=what, computing="", **shown)

    def take(self, kind: str, value: Any = None, *, seen: int | None = None) -> str:
        """The page's answer (``pose``, ``decision``, ``note`` or ``quit``), taken for the
        recorder if it is offered now (returns ""), else why not in the operator's words.
        A pose or decision taken closes the offer, and the page says at once what the
        recorder does with it. ``seen``: the decision offer the page answers (its state's
        ``offer``; 0: it showed none, a key pressed meanwhile): a decision is taken only for
        the capture the operator saw, never for one that ended after the click."""
        with self.lock:
            why = self._not_now(kind, value)
            if not why and kind == "decision" and seen not in (None, self.offer_id):
                why = (
                    f"not now: given before trial {self.trial} pose {self.pose}'s decision "
                    "was asked for; decide it again"
                )
            if why:
                return why
            self._answers.append((kind, value))
            if kind == "quit":
                self.quitting, self.waiting = True, ""
                self.message, self.level = "quit: the session is being closed", "info"
            elif kind == "pose":
                self.waiting = ""
                self.message = f"trial {self.trial} pose {self.pose}: capturing"
            elif kind == "decision":
                self.waiting = ""
                self._decided(value[0])
            elif kind in ("start", "end"):  # a stream trial starts or ends: said at once
                self.waiting = ""
                self.message = f"trial {self.trial + (kind == 'start')}: " + (
                    "starting its stream" if kind == "start" else "ending its stream"
                )
            self.lock.notify_all()
            return ""

    def answer(self, timeout_s: float) -> tuple[str, Any] | None:
        """The next answer taken, in the order given (None: none within ``timeout_s``);
        raises KeyboardInterrupt once the server stops."""
        with self.lock:
            self.lock.wait_for(lambda: bool(self._answers) or self._interrupted, timeout_s)
            if self._interrupted:
                raise KeyboardInterrupt
            return self._answers.popleft() if self._answers else None

    def interrupt(self) -> None:
        """The server stops (Ctrl-C, SIGTERM): the recording ends as at the terminal."""
        with self.lock:
            self._interrupted = True
            self.lock.notify_all()

    def _not_now(self, kind: str, value: Any) -> str:
        """Why the answer cannot be taken now ("": it can), in the operator's words."""
        if self.phase != "recording":
            return {"setup": "not now: start the session first (the setup)"}.get(
                self.phase, "not now: the session is over"
            )
        if self.quitting:
            return "not now: quit was taken; the session is being closed"
        if kind == "quit":
            return ""
        offered = next((w for w, kinds in ANSWERS.items() if kind in kinds), "")
        if self.waiting != offered:
            if kind == "note":
                return "add a note after a capture (it goes with that trial)"
            if kind == "touch":
                return "not now: a touch is marked while a trial streams (start the trial)"
            return self._busy()
        return self._refusal(value[0]) if kind == "decision" else ""

    def _busy(self) -> str:
        """What the recorder is doing instead of what was asked, in words."""
        decided = [value[0] for kind, value in self._answers if kind == "decision"]
        if decided:
            said = decided[-1].replace("_", " ")
            return f"not now: {said} was taken for trial {self.trial} pose {self.pose}"
        if self.computing:
            return f"not now: {self.computing}"
        if self.waiting == "pose":
            return f"not now: the recorder waits for pose {self.pose} to be typed and captured"
        if self.waiting == "decision":
            return f"not now: trial {self.trial} pose {self.pose} awaits its decision"
        if self.waiting == "streaming":
            return f"not now: trial {self.trial} streams; end it first"
        if self.waiting == "trial":
            return "not now: no trial streams; start one"
        frame, n_frames = self.capture.get("frame", 0), self.capture.get("n_frames", 0)
        if self.frames_of == {"trial": self.trial, "pose": self.pose} and frame < n_frames:
            return (
                f"not now: trial {self.trial} pose {self.pose} is being captured (frame "
                f"{frame} of {n_frames}); decide once it is done"
            )
        return f"not now: {self.message}"

    def _refusal(self, choice: str) -> str:
        """Why the decision offered now cannot be ``choice`` ("": it can)."""
        what = "the board" if self.board is not None else "the target"
        if choice == "undo" and self.pose <= 1:
            return (
                f"nothing to undo: this is the first pose of trial {self.trial}; "
                "redo captures it again"
            )
        if choice in self.offers or (choice == "accept_anyway" and "accept" in self.offers):
            return ""
        if self.shortfall == Shortfall.NONE_FOUND.value:
            return f"{what} was not found in any frame, so this pose has nothing to measure: redo"
        if self.shortfall == Shortfall.FEW_FOUND.value:
            return f"{what} was found in fewer than half the frames: redo, or accept anyway"
        return f"{choice.replace('_', ' ')} is not offered for this capture: {self.message}"

    def _decided(self, choice: str) -> None:
        """The page says what the recorder does with the decision taken (every control off):
        the trial's result and the next pose (or the rig's check), the pose listed as
        decided; the procedure's own refusal offers the decision again."""
        what = (
            "checking what the poses so far say of the rig"
            if self.board is not None
            else "computing the trial's result and the next pose to suggest"
        )
        self.computing = (
            f"trial {self.trial} pose {self.pose} {_DONE.get(choice, 'accepted')}: {what}; "
            "the form comes back when it is done"
        )
        rows = list(self.poses)
        if rows and rows[-1]["state"] == "awaiting decision":
            current = rows.pop()
            if choice in ("accept", "accept_anyway"):
                rows.append({**current, "state": "accepted"})
            elif choice == "undo":
                rows = [r for r in rows if r["pose"] != current["pose"] - 1]
        self.poses = rows

    def method_spec(self) -> MethodSpec | None:
        """The session's method's spec (None before the setup is accepted)."""
        return None if self.method is None else spec_of(self.method)

    def begin(self, setup: Setup, rig: RigConstants | None) -> None:
        """The setup is accepted: recording starts, and what it records stays in view.

        The page shows the setup line's entries in this order, each named by its key (a
        board session's board in place of the ground truth; empty ones left out)."""
        k = setup.intrinsics
        line: dict[str, Any] = {
            "method": setup.method.value,
            "units": setup.units.value,
            "camera": f"f {shown(k.fx)} px, principal point ({shown(k.cx)}, {shown(k.cy)}) px, "
            f"{k.width}x{k.height}",
        }
        if setup.board is not None:
            b = setup.board
            line["board"] = (
                f"{b.inner_corners[0]}x{b.inner_corners[1]} inner corners, squares of "
                f"{shown(b.square)} {setup.units.value}, first corner at "
                f"({', '.join(shown(v) for v in b.first_corner)})"
            )
        else:
            # As typed (4.8514, never the page's 4.851): the page shows text as it is.
            line["truth"] = [[shown(x) for x in p] for p in setup.ground_truth]
        line |= {
            # The method's plane (method 2's ground height): its words and offset.
            "plane": _plane_line(setup),
            "rig": "" if rig is None else "a calibrated rig corrects the live result",
            "operator": setup.operator,
            "stop_rule": "" if setup.board is not None else stop_rule(setup),
        }
        if self.continuing is not None:
            c = self.continuing
            line["continues"] = f"{c['file']} after trial {c['after_trial']}"
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
            self.refusal = {
                "control": control, "message": message, "seq": self._refusals,
                "offer": self.offer_id,
            }  # fmt: skip
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
        from twopose.methods.planes import GROUND_PLANE
        from twopose.methods.topview import top_view

        with self.lock:
            self.results[result.trial] = result.to_json()
            # From above whatever the method's plane: the page draws the paper's map and
            # the suggested pose (x, z) on the same canvas.
            view = None if scene is None else top_view(scene, GROUND_PLANE)
            self.topview = None if view is None else view.to_json()
            self.lock.notify_all()

    def withdraw(self, trial: int) -> None:
        """The trial's result is gone (an undo left it fewer than two poses)."""
        with self.lock:
            self.results.pop(trial, None)
            if self.topview is not None and self.topview.get("trial") == trial:
                self.topview = None
            self.lock.notify_all()

    def next_frame(self, after: int, timeout_s: float) -> _Frame | None:
        """The newest frame after sequence number ``after`` (None: none came in time, or
        the server is closing)."""
        with self.lock:
            self.lock.wait_for(
                lambda: (
                    self.closing.is_set() or (self.latest is not None and self.latest.seq > after)
                ),
                timeout=timeout_s,
            )
            latest = self.latest
            return latest if latest is not None and latest.seq > after else None


def stop_rule(setup: Setup) -> str:
    """The stop rule in force, as the page's setup line says it."""
    if setup.target95 is None:
        return "none (suggestions only)"
    within = f"{shown(setup.target95)} {setup.units}"
    return f"a trial is complete once its 95% region is within {within}"


def vec_json(v: Vec3) -> list[float]:
    """Three numbers as the page's JSON takes them (a list of floats)."""
    return [float(x) for x in v]


def _plane_line(setup: Setup) -> dict[str, Any] | None:
    """The setup line's plane: its offset's words and value (None: the method has none)."""
    plane = spec_of(setup.method).plane
    if plane is None or setup.plane_offset is None:
        return None
    return {"words": plane.bound.words, "offset": shown(setup.plane_offset)}
