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
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from recorder.interactive import Operator, Setup, ask_setup, parse_vector
from recorder.procedure import (
    Decision,
    Driver,
    Placement,
    ProcedureRefusedError,
    QuitRecording,
    RecordingSummary,
)
from twopose.errors import InputValueError
from twopose.format.entries import GroundTruth, Note, PoseEntry, TruthKind, TypedEntry
from twopose.values import Vec3

if TYPE_CHECKING:
    from recorder.capture import CaptureResult
    from recorder.sources import FrameSource, SourceInfo
    from twopose.detect import Detection
    from twopose.scene3d import TrialScene
    from twopose.trial_result import TrialResult

__all__ = ["FORM_QUESTIONS", "ConsoleSession", "WebDriver", "setup_from_form"]

#: The setup form's fields, by the start of the terminal question each one answers.
FORM_QUESTIONS = {
    "method": "method",
    "units": "units",
    "focal parameter": "focal",
    "principal point": "principal",
    "ground height": "ground_height",
    "ground truth point 1": "truth1",
    "ground truth point 2": "truth2",
    "keep this ground truth anyway": "keep_off_ground",
    "operator": "operator",
}


class _FormRefusedError(InputValueError):
    pass


def setup_from_form(form: dict[str, str], **given: Any) -> Setup:
    """The setup a form describes, checked by the terminal's questions: each question is
    answered from its field (empty: the question's default); a refused answer raises
    :class:`InputValueError` naming the field and saying why."""
    refusal: list[str] = []
    asked: set[str] = set()

    def answer(question: str, default: str) -> str:
        field = next((f for q, f in FORM_QUESTIONS.items() if question.startswith(q)), None)
        if field is None:
            raise InputValueError(f"the form has no field for {question!r}")
        if field in asked:  # asked again: the last answer was refused
            raise _FormRefusedError(f"{field}: {refusal[-1] if refusal else 'not accepted'}")
        asked.add(field)
        text = str(form.get(field, "") or "").strip()
        if field == "keep_off_ground":
            return "y" if text.lower() in ("y", "yes", "true", "on", "1") else "n"
        return text or default

    def say(line: str) -> None:
        refusal.append(line.strip().removeprefix("not accepted: "))

    return ask_setup(Operator(answer, say), **given)


@dataclass
class _Frame:
    data: bytes  # JPEG as stored (or a preview's)
    detection: Detection | None
    seq: int


class ConsoleSession:
    """What the page shows and what it asks, shared by the server and the recording
    thread (every access under one lock). It is also the recorder's live sink
    (:class:`recorder.capture.LiveSink`): frames, status and trial results arrive here."""

    def __init__(self, out: Path) -> None:
        self.out = out
        self.lock = threading.Condition()
        self.commands: queue.Queue[tuple[str, Any]] = queue.Queue()
        self.phase = "setup"  # setup, recording, done, failed
        self.setup_fields: list[str] = list(dict.fromkeys(FORM_QUESTIONS.values()))
        self.method = ""
        self.units = ""
        self.waiting = ""  # pose, decision, or "" (capturing, between steps)
        self.trial = self.pose = self.n_poses = 0
        self.capture = {"frame": 0, "n_frames": 0}
        self.message = "fill in the setup"
        self.last_capture = ""
        self.results: dict[int, dict[str, Any]] = {}
        self.topview: dict[str, Any] | None = None
        self.summary = ""
        self.latest: _Frame | None = None
        self.viewers = 0  # pages watching the live image (the preview runs only for them)
        self.preview_at = 0.0  # monotonic time of the last preview frame

    # -- the page's view
    def snapshot(self) -> dict[str, Any]:
        with self.lock:
            return {
                "phase": self.phase,
                "out": str(self.out),
                "method": self.method,
                "units": self.units,
                "waiting": self.waiting,
                "trial": self.trial,
                "pose": self.pose,
                "n_poses": self.n_poses,
                "capture": dict(self.capture),
                "message": self.message,
                "last_capture": self.last_capture,
                "results": [self.results[t] for t in sorted(self.results)],
                "topview": self.topview,
                "summary": self.summary,
                "frame_seq": self.latest.seq if self.latest else 0,
            }

    def update(self, **fields: Any) -> None:
        with self.lock:
            for name, value in fields.items():
                setattr(self, name, value)
            self.lock.notify_all()

    # -- the recorder's live sink
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
            self.latest = _Frame(data, detection, seq)
            self.lock.notify_all()

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
        self.update(capture={"frame": frame, "n_frames": n_frames}, message=message)

    def trial_result(self, result: TrialResult, scene: TrialScene | None, log_time_ns: int) -> None:
        with self.lock:
            self.results[result.trial] = result.to_json()
            self.topview = _topview(result, scene)
            self.lock.notify_all()

    def next_frame(self, after: int, timeout_s: float) -> _Frame | None:
        """The newest frame after sequence number ``after`` (None: none came in time)."""
        with self.lock:
            self.lock.wait_for(
                lambda: self.latest is not None and self.latest.seq > after, timeout=timeout_s
            )
            latest = self.latest
            return latest if latest is not None and latest.seq > after else None


def _topview(result: TrialResult, scene: TrialScene | None) -> dict[str, Any] | None:
    """The trial seen from above (x, z): camera centres, where each view's ray or plane
    points, the estimate and the truth; for the page's canvas."""
    if scene is None:
        return None
    k = scene.intrinsics
    cam = np.stack([(scene.px[:, 0] - k[:, 2]) / k[:, 0], (scene.px[:, 1] - k[:, 3]) / k[:, 1]])
    rays = np.einsum("nij,nj->ni", scene.R_cam_to_grid, np.vstack([cam, np.ones(len(k))]).T)
    reach = np.linalg.norm(np.asarray(result.point) - scene.t_grid, axis=1) * 1.2
    ends = scene.t_grid + rays / np.linalg.norm(rays, axis=1, keepdims=True) * reach[:, None]
    truth = scene.truth.mean(axis=0)

    def xz(p: Any) -> list[float] | None:
        p = np.asarray(p, dtype=np.float64)
        return [float(p[0]), float(p[2])] if np.isfinite(p).all() else None

    return {
        "trial": result.trial,
        "cameras": [xz(c) for c in scene.t_grid],
        "ray_ends": [xz(e) for e in ends],
        "estimate": xz(result.point),
        "truth": xz(truth),
    }


class WebDriver(Driver):
    """The page decides: the pose form captures, the buttons decide, quit ends. While it
    waits for the operator it shows the camera live (preview frames, not recorded)."""

    def __init__(
        self,
        session: ConsoleSession,
        source: FrameSource | None,
        camera_id: str,
        ground_truth: tuple[Vec3, ...],
        poses_per_trial: int,
        resolution: tuple[float, float],
        preview: Callable[[FrameSource, ConsoleSession], None] | None = None,
    ) -> None:
        self.session, self.source, self.camera_id = session, source, camera_id
        self.ground_truth = ground_truth
        self.poses_per_trial = poses_per_trial
        self.resolution = resolution
        self.preview = preview
        self._note = ""
        self._pending: tuple[str, Any] | None = None  # a pose typed before its trial began
        self.fps = 30.0

    def start(self, source: SourceInfo, path: Path) -> None:
        self.fps = source.fps
        self.session.update(phase="recording", message=f"recording {path}")

    def next_trial(self, trial: int) -> bool:
        """The first trial begins at once; another when its first pose is typed (quit
        instead ends the session, with no empty trial left in the file)."""
        if trial == 1:
            return True
        self.session.update(
            trial=trial, pose=1, message=f"trial {trial}: type pose 1, then capture (or quit)"
        )
        try:
            self._pending = self._wait("pose")
        except QuitRecording:
            return False
        return True

    def trial_entries(self, trial: int) -> tuple[TypedEntry, ...]:
        self.session.update(trial=trial, n_poses=self.poses_per_trial)
        if not self.ground_truth:
            return ()
        kind: TruthKind = "line" if self.session.method == "line" else "point"
        return (GroundTruth(trial, kind, self.ground_truth),)

    def _wait(self, what: str) -> tuple[str, Any]:
        """The page's next command for ``what`` (pose or decision); quit ends it all."""
        self.session.update(waiting=what)
        while True:
            try:
                command = self.session.commands.get(timeout=0.05)
            except queue.Empty:
                if self.preview is not None and self.source is not None:
                    self.preview(self.source, self.session)
                continue
            if command[0] == "quit":
                self.session.update(waiting="")
                raise QuitRecording
            if command[0] in _EXPECTED[what]:
                self.session.update(waiting="")
                return command

    def place(self, trial: int, pose: int) -> Placement:
        self.session.update(pose=pose, message=f"trial {trial}: type pose {pose}, then capture")
        command, self._pending = self._pending or self._wait("pose"), None
        _, (t, r) = command
        self.session.update(message=f"trial {trial} pose {pose}: capturing")
        return Placement(PoseEntry(trial, pose, self.camera_id, t, r, *self.resolution))

    def captured(self, trial: int, pose: int, result: CaptureResult) -> None:
        state = "complete" if result.complete else f"INCOMPLETE ({result.reason})"
        overhead = float(np.mean(result.overhead_s)) * self.fps if result.overhead_s else 0.0
        self.session.update(
            last_capture=f"trial {trial} pose {pose}: {result.n_frames} frames, "
            f"{result.n_found} detected, {state}, {result.dropped} dropped; recorder "
            f"overhead {100 * overhead:.0f}% of the frame interval",
            message=f"trial {trial} pose {pose}: accept, redo, undo, note or quit",
        )

    def decide(self, trial: int, pose: int, result: CaptureResult) -> Decision:
        kind, value = self._wait("decision")
        if kind == "note":
            self._note = str(value)
            return Decision.NOTE
        return Decision(value)

    def note(self, trial: int) -> Note:
        self.session.update(message=f"note added to trial {trial}")
        return Note(self._note, trial)

    def refused(self, error: ProcedureRefusedError) -> None:
        self.session.update(message=f"not possible: {error}")

    def trial_result(self, result: TrialResult) -> None:
        self.session.update(message=result.text())

    def finish(self, summary: RecordingSummary) -> None:
        self.session.update(phase="done", waiting="", summary=summary.line())


_EXPECTED = {"pose": {"pose"}, "decision": {"decision", "note"}}
DECISIONS = {"accept": "a", "redo": "r", "undo": "u"}


def parse_pose(form: dict[str, str], units: str) -> tuple[Vec3, Vec3]:
    """The pose form, checked as the terminal checks a typed pose."""
    xyz = ", ".join(str(form.get(k, "")).strip() or "?" for k in ("x", "y", "z"))
    t = parse_vector(xyz, units)
    rotation = str(form.get("rotation", "") or "").strip() or "0, 0, 0"
    r = parse_vector(rotation, units, what="rotation", limit=180.0)
    return t, r
