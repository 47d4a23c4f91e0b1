"""The web console's stream trials: a pair's session in the browser (``new --pair --ui``).

:class:`WebStreamDriver` is the :class:`recorder.procedure.stream.StreamDriver` the
console's recording thread runs (:func:`record_pair_thread`): the page decides through the
one state (:class:`recorder.console.state.ConsoleSession`), as for one camera. Its steps:

=============  ==============================  ===========================================
offered        the page's answer               what the recorder does
=============  ==============================  ===========================================
``trial``      ``start`` (start trial)         opens the next trial's stream
``streaming``  ``touch`` (x, y, z; the button)  marks a touch at that grid point, now (the
                                                server's monotonic clock when the request
                                                came: the button's time)
``streaming``  ``end`` (end trial)              closes the trial's stream
any            ``quit`` (stop)                  ends the trial and the session
=============  ==============================  ===========================================

``POST /api/stream`` takes them (``action``: start, touch, end, stop; a touch's ``x, y, z``
read by the ground truth's quantity in the session's units). The state's ``stream`` says
the trial, its touches, its frames per camera, the clock offset and the trials ended. The
setup comes from the command line (asked at the terminal before the page is served).
"""

from __future__ import annotations

import functools
import threading
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from typing_extensions import override

from recorder.console.driver import said_ended, said_failed
from recorder.procedure import stops
from recorder.procedure.stream import (
    StreamDriver,
    StreamEvent,
    StreamSink,
    StreamSummary,
    TrialEnd,
)
from recorder.setup.stream_plan import touch_refusal
from twopose.methods.specs import spec_of
from twopose.values.bounds import shown

if TYPE_CHECKING:
    from recorder.console.state import ConsoleSession
    from recorder.live.pointing_feed import PointingFeed
    from recorder.live.pointing_thread import PointingThread
    from recorder.procedure.stream_terminal import PairSetup
    from recorder.sources.pair import CameraStream, PairSource, TimedFrame
    from twopose.format.entries import Touch
    from twopose.pair.calibration import PairCalibration
    from twopose.pair.clock import ClockOffset

__all__ = [
    "PREVIEW_FPS",
    "STREAM_LIMITS",
    "WebStreamDriver",
    "begin_pair",
    "record_pair_thread",
    "start_pair_recording",
    "stream_answer",
]

#: How often camera 1's frame is shown live while a trial streams (the page's image).
PREVIEW_FPS = 10.0


def _point(p: Any) -> str:
    return f"({', '.join(shown(v) for v in p)})"


def begin_pair(session: ConsoleSession, setup: PairSetup, pair: PairCalibration) -> None:
    """The pair's session starts recording: what it records stays in view."""
    plane = None  # the method's plane (ground): the pair file's floor, or typed
    if spec_of(setup.method).plane is not None:
        offset = (
            "the pair file's floor" if setup.plane_offset is None else shown(setup.plane_offset)
        )
        plane = {"words": "floor", "offset": offset}
    session.update(
        method=setup.method, units=setup.units, phase="recording",
        session_setup={
            "method": setup.method.value, "units": setup.units.value,
            "camera": f"a pair: camera 1 {pair.intrinsics1.width}x{pair.intrinsics1.height}, "
            f"baseline {pair.baseline:.4g} {pair.units}",  # as calibrate-pair says it
            "plane": plane,
            "operator": setup.operator, "stop_rule": "",
        },
        # the trial before the first (the page offers the next: a continuation's numbered on)
        stream={"trial": setup.first_trial - 1, "touches": [], "frames": [0, 0], "offset": "",
                "ended": []},
    )  # fmt: skip
    session.touch_refusal = functools.partial(touch_refusal, setup.method, pair, setup.units)
    continued = setup.continued
    if continued is not None:  # said first, as a one-camera continuation's page says it
        session.update(
            notices=[
                *session.notices,
                f"Continuing {continued.path.name} after trial {continued.last_trial}: its "
                f"pair and setup; trials from {continued.next_trial}",
            ]
        )


class WebStreamDriver(StreamDriver):
    """The page decides (the module docstring)."""

    def __init__(self, session: ConsoleSession, pointing: PointingThread | None = None) -> None:
        self.session = session
        self.pointing = pointing  # the live pointing: told the clock offset measured

    def _stream(self, **fields: Any) -> None:
        with self.session.lock:
            current = dict(self.session.stream or {})
            current.update(fields)
            self.session.update(stream=current)

    @override
    def start(self, cameras: tuple[CameraStream, CameraStream], path: Path) -> None:
        said = "; ".join(f"camera {n}: {c.text()}" for n, c in enumerate(cameras, start=1))
        self.session.update(notices=[*self.session.notices, said])

    @override
    def next_trial(self, trial: int) -> bool:
        self.session.offer(
            "trial", trial=trial - 1, message=f"trial {trial}: start its stream when the target "
            "is ready, or stop to finish the session", level="info",
        )  # fmt: skip
        while True:
            stops.check()  # the server is stopping
            answer = self.session.answer(timeout_s=0.05)
            if answer is None:
                continue
            return answer[0] == "start"

    @override
    def events(self) -> list[StreamEvent]:
        events = []
        while (answer := self.session.answer(timeout_s=0.0)) is not None:
            kind, value = answer
            if kind == "touch":
                point, at_ns = value
                events.append(StreamEvent(kind="touch", at_ns=at_ns, point=point, how="button"))
            elif kind == "end":
                events.append(StreamEvent(kind="end"))
            elif kind == "quit":
                events.append(StreamEvent(kind="quit"))
        return events

    @override
    def streaming(self, trial: int) -> None:
        self._stream(trial=trial, touches=[], frames=[0, 0])
        self.session.offer(
            "streaming", trial=trial, message=f"trial {trial} streams: type the grid point, "
            "press touch the moment the target is on it; end trial when done", level="info",
        )  # fmt: skip

    @override
    def touched(self, touch: Touch) -> None:
        with self.session.lock:
            touches = [*(self.session.stream or {}).get("touches", [])]
            touches.append({"touch": touch.touch, "point": list(touch.point), "how": touch.how})
            self._stream(touches=touches)
            self.session.update(
                message=f"trial {touch.trial}: touch {touch.touch} at {_point(touch.point)} "
                f"({touch.how}); streaming",
                level="info",
            )

    @override
    def refused(self, message: str) -> None:
        self.session.refuse("touch", message)

    @override
    def trial_ended(self, end: TrialEnd) -> None:
        with self.session.lock:
            ended = [*(self.session.stream or {}).get("ended", []), end.line()]
            self._stream(ended=ended, frames=list(end.n_frames))
            self.session.update(
                message=end.line(), level="info" if end.complete else "warning",
                # what an answer before the next trial is told (its offset is measured now)
                computing=f"trial {end.trial} is closing (the clocks' offset is being "
                "measured from its frames): wait a moment",
            )  # fmt: skip

    @override
    def offset(self, trial: int, offset: ClockOffset | None, said: str) -> None:
        words = "" if offset is None else (
            f"{offset.offset_ns / 1e6:+.2f} ± {offset.sigma_ns / 1e6:.2f} ms ({offset.method})"
        )  # fmt: skip
        self._stream(offset=words, offset_said=said)
        self.session.update(computing="")
        if offset is not None and self.pointing is not None:
            self.pointing.use_offset(offset)

    @override
    def finish(self, summary: StreamSummary) -> None:
        self.session.update(phase="done", waiting="", summary=summary.line())


class _Preview(StreamSink):
    """Camera 1's frames to the page's live image, at :data:`PREVIEW_FPS` at most, and
    every frame to the live pointing panel (``pointing``, on its own thread)."""

    def __init__(self, session: ConsoleSession, pointing: PointingThread | None = None) -> None:
        self.session = session
        self.pointing = pointing
        self._last_ns = 0
        self._counts = [0, 0]

    @override
    def pair_frame(self, frame: TimedFrame) -> None:
        import cv2

        if self.pointing is not None:
            self.pointing.give(frame)
        self._counts[frame.camera - 1] += 1
        if frame.camera != 1 or frame.t_grab_ns - self._last_ns < 1e9 / PREVIEW_FPS:
            return
        self._last_ns = frame.t_grab_ns
        ok, data = cv2.imencode(".jpg", frame.image, [cv2.IMWRITE_JPEG_QUALITY, 80])
        if ok:
            self.session.frame("cam1", bytes(data), "jpeg", frame.t_capture_ns, None, "")
            with self.session.lock:
                stream = dict(self.session.stream or {})
                stream["frames"] = list(self._counts)
                self.session.update(stream=stream)


def start_pair_recording(
    session: ConsoleSession,
    options: _Recording,
    pair: PairCalibration,
    setup: PairSetup,
    pointing: PointingFeed | None = None,
) -> threading.Thread:
    """The pair's source opened and its recording thread started (``options``: the
    console's source, fps and notes; ``pointing``: the live pointing panel's feed, which
    the recording's frames feed: :mod:`recorder.live.pointing_thread`)."""
    from recorder.procedure.stream_terminal import open_pair_source

    source = open_pair_source(options.source, pair, setup, fps=options.fps)
    begin_pair(session, setup, pair)
    thread = threading.Thread(
        target=record_pair_thread,
        args=(session, setup, pair, source, options.notes, pointing),
        name="recording",
        daemon=True,
    )
    thread.start()
    return thread


class _Recording(Protocol):
    """What :func:`start_pair_recording` reads of the console's options."""

    source: str
    fps: float
    notes: str


#: ``POST /api/stream``'s fields and their longest text.
STREAM_LIMITS = {"action": 10, "x": 50, "y": 50, "z": 50}


def stream_answer(
    session: ConsoleSession, form: dict[str, str], at_ns: int
) -> tuple[str, dict[str, str]]:
    """``POST /api/stream``'s ``action`` (start, touch with its ``x, y, z`` marked at
    ``at_ns``: when the request came, end or stop) taken for the recorder; or why not and
    the refusal by field ("": taken)."""
    from recorder.setup.form import FormRefusedError, parse_touch_form

    action, units = form.get("action", ""), session.units
    if action not in ("start", "touch", "end", "stop"):
        return f"action must be start, touch, end or stop, not {action!r}", {}
    value: Any = None
    if action == "touch":
        if units is None or session.waiting != "streaming":
            return session.take("touch") or "not now: no trial streams", {}
        try:
            point = parse_touch_form(form, units)
        except FormRefusedError as err:
            return str(err), err.errors
        off = session.touch_refusal(point)
        if off:  # a ground touch off the floor
            session.refuse("touch", off)
            return off, {"touch": off}
        value = (point, at_ns)
    why = session.take("quit" if action == "stop" else action, value)
    if why:
        session.refuse(action, why)
    return why, {action: why} if why else {}


def record_pair_thread(
    session: ConsoleSession,
    setup: PairSetup,
    pair: PairCalibration,
    source: PairSource,
    notes: str = "",
    pointing: PointingFeed | None = None,
) -> None:
    """The console's recording thread for a pair: stream trials as the page says (and
    each frame to the live pointing panel's ``pointing`` feed); the summary printed once
    when it ends."""
    from recorder.procedure.stream import record_stream
    from recorder.procedure.stream_terminal import pair_cameras

    live = _pointing(setup, pair, pointing)
    driver = WebStreamDriver(session, live)
    driver.first_trial = setup.first_trial  # a continuation's: after its session's last
    try:
        summary = record_stream(
            session.out, setup.info(notes), pair_cameras(pair), pair, source,
            driver, ground=setup.ground(), sink=_Preview(session, live),
        )  # fmt: skip
        said_ended(summary.line(), stopped=session.closing.is_set() or stops.requested())
    except Exception as err:  # the page must say it, not a thread's traceback
        said_failed(session, err)
    finally:
        if live is not None:
            live.close("the recording ended")


def _pointing(
    setup: PairSetup, pair: PairCalibration, feed: PointingFeed | None
) -> PointingThread | None:
    """The live pointing beside the recording (None: no feed, or the method cannot point:
    the panel then says why)."""
    import dataclasses

    import numpy as np

    from recorder.console.pointing_server import about
    from recorder.live.pointing import LivePointing
    from recorder.live.pointing_thread import PointingThread
    from twopose.errors import TwoposeError
    from twopose.pair.calibration import FloorPlane

    if feed is None:
        return None
    typed = setup.ground()
    if pair.floor is None and typed is not None and typed.offset > 0:
        # no floor in the pair file: the typed plane (camera 1's frame is the grid's), exact
        floor = FloorPlane(normal=np.asarray(typed.normal_grid, dtype=np.float64),
                           height=typed.offset, cov=np.zeros((4, 4)))  # fmt: skip
        pair = dataclasses.replace(pair, floor=floor)
    try:
        live = LivePointing(setup.method, pair)
    except TwoposeError as err:
        feed.stop(f"no pointing: {err}")
        return None
    return PointingThread(live, feed, about(setup.method, pair))
