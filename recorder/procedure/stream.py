"""Stream trials: a pair's recording, trial by trial (issue 58 item 4).

With a pair (``twopose-record new OUT.mcap --pair PAIR.toml --source pair:A,B``) a trial
is a **stream**: both cameras' frames flow into the trial's stream window
(:meth:`twopose.format.writer.SessionWriter.stream`), the target moves, no pose is typed,
and the moments the target is at a known grid point are marked as **touches**, three ways:

- ``key``: the operator presses Enter at the terminal at the moment of the touch
  (:mod:`recorder.procedure.stream_terminal`);
- ``button``: the console's touch button (:mod:`recorder.console.stream_driver`);
- ``schedule``: a plan's touches, each a point and a time after the trial's start
  (:mod:`recorder.setup.stream_plan`).

A touch's time is on **camera 1's capture clock** (the format's ``/twopose/touch``). A key
or a button is stamped with the monotonic clock when it arrives (:class:`StreamEvent`);
where camera 1's capture clock is the monotonic clock (a driver's stamps, the monotonic
clock at grab, a video file or the synthetic camera paced from the pair's start) that is
the touch's time. Files alone (video files, folders) are replayed whole
(:meth:`recorder.sources.pair.PairSource.replay`: every frame in order, the first trial
from the files' first frames), so that the same files and plan give the same session; a
replay has no operator's time (a folder's stills none at all, a video's frames recorded at
the machine's pace), and a key or a button is then the capture time of camera 1's frame
last recorded, the one the operator sees. A
trial's **start** is its first camera-1 frame's capture time; a scheduled touch is written
when camera 1's clock passes it (one never reached, the trial ended first, is said).

**The lag between a key and the frames.** The touch is stamped when the line reaches the
recorder: the terminal and the key thread add well under a millisecond. The operator is
slower: a person presses a key some 0.15-0.3 s after seeing the finger arrive (a simple
reaction time), so a key marks a moment *within* the finger's stay on the point, not its
arrival: keep the finger still on the point for half a second or more and press while it
is there. On a camera whose capture clock is the monotonic clock at grab (no driver stamp,
the session's ``clocks`` says it), that camera's stamps are themselves late by its
driver's latency; the same latency is in camera 1's stamps and in the touch's (both
taken on arrival), except that the frame showing the finger at the key was grabbed one
latency later, so with such a camera a touch is read that latency early: again harmless
while the finger stays.

The clock offset between the cameras is measured as the trials go
(:mod:`recorder.procedure.stream_offset`: the rays' smallest gap of the moving target) and
recorded (``/twopose/clock_offset``) after each trial that fixes it, pooled over the
session's trials; a trial that cannot fix it is said, and a session where none could
records none (the analysis then measures it per trial, or says it cannot).

Every stop closes the file: Ctrl-C (SIGTERM, SIGHUP), quit (``q``, the console's stop), a
camera that stops or sends nothing for :data:`SILENT_S` (the trial's last window closed
``incomplete`` with the reason). A kill -9 loses at most the open window (``recover``).
"""

from __future__ import annotations

import contextlib
import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import TYPE_CHECKING, Literal

from recorder.procedure import stops
from recorder.procedure.machine import refuse_existing
from recorder.procedure.stream_offset import OffsetMeter
from recorder.procedure.stream_source import check_sizes, first_frames, with_clocks
from recorder.setup.stream_plan import touch_refusal
from twopose.errors import SourceError, TwoposeError
from twopose.format.entries import Note
from twopose.format.stream_entries import TouchMark
from twopose.format.writer import SessionWriter
from twopose.values.checks import Vec3

if TYPE_CHECKING:
    from recorder.sources.pair import CameraStream, PairSource, TimedFrame
    from twopose.camera.model import Camera
    from twopose.format.entries import PlaneEntry, SessionInfo, Touch
    from twopose.format.windows import Stream
    from twopose.pair.calibration import PairCalibration
    from twopose.pair.clock import ClockOffset

__all__ = [
    "SILENT_S",
    "ScheduledTouch",
    "StreamDriver",
    "StreamEvent",
    "StreamSink",
    "StreamSummary",
    "TrialEnd",
    "record_stream",
]

#: A camera that sends no frame for this long has stopped: the trial ends, the file closes
#: (every stop within 2 s).
SILENT_S = 1.0
#: A stream's windows: closed and synced to disk this often (a kill -9 loses at most one).
WINDOW_S = 1.0


@dataclass(frozen=True, kw_only=True)
class StreamEvent:
    """What the operator did during a stream trial: ``touch`` (the target is at ``point``
    now; None: the next point the driver knows, refused if none), ``end`` the trial, or
    ``quit`` the session; ``at_ns`` when (``time.monotonic_ns()`` as the key or button
    arrived), ``how`` it was marked."""

    kind: Literal["touch", "end", "quit"]
    at_ns: int = 0
    point: Vec3 | None = None
    how: TouchMark = "key"


@dataclass(frozen=True, kw_only=True)
class ScheduledTouch:
    """A plan's touch: the target is at ``point`` ``after_s`` seconds after the trial's
    start (its first camera-1 frame's capture time)."""

    point: Vec3
    after_s: float


#: How a trial ends as asked (by the operator, its duration, or its sources' end).
_ASKED_ENDS = ("end", "duration", "quit", "ended")


@dataclass(frozen=True, kw_only=True)
class TrialEnd:
    """How a stream trial ended: ``why`` (``end``, ``duration``, ``quit``, ``ended``: both
    files or folders ran out, ``interrupted``, or a camera's failure in words), its frames
    per camera, its touches, the scheduled touches never reached, the trial's seconds on
    camera 1's clock."""

    trial: int
    why: str
    n_frames: tuple[int, int]
    touches: tuple[Touch, ...]
    missed: tuple[ScheduledTouch, ...] = ()
    seconds: float = 0.0
    dropped: tuple[int, int] = (0, 0)
    #: A video file's frames played before the trial started, per camera: not recorded.
    unrecorded: tuple[int, int] = (0, 0)

    @property
    def complete(self) -> bool:
        """Ended as asked, with frames from both cameras and a touch to measure."""
        return not self.lacking and self.why in _ASKED_ENDS

    @property
    def lacking(self) -> str:
        """What a trial that ended as asked lacks to measure anything ("": nothing)."""
        silent = [f"camera {c}" for c, n in enumerate(self.n_frames, start=1) if n == 0]
        if silent:
            return f"no frames from {' or '.join(silent)}"
        return "" if self.touches else "no touches (nothing to measure)"

    def line(self) -> str:
        """The trial as the terminal says it when it ends."""
        (n1, n2), (d1, d2) = self.n_frames, self.dropped
        how = ", ".join(
            f"{sum(t.how == h for t in self.touches)} by {h}"
            for h in ("key", "button", "schedule")
            if any(t.how == h for t in self.touches)
        )
        said = f"trial {self.trial}: {self.seconds:.1f} s, frames {n1} + {n2}"
        said += f" ({d1} + {d2} dropped), {len(self.touches)} touch"
        said += "es" if len(self.touches) != 1 else ""
        said += f" ({how})" if how else ""
        if any(self.unrecorded):
            said += (
                f"; {self.unrecorded[0]} + {self.unrecorded[1]} of the files' frames played "
                "before the trial started, not recorded (a video plays at its rate from when "
                "it is opened, as a camera does)"
            )
        if self.why == "ended":
            said += "; the sources ended (no more frames)"
        if self.missed:
            said += f"; {len(self.missed)} scheduled touch(es) not reached: the trial ended first"
        if self.complete:
            return said
        return said + f"; incomplete: {self.lacking if self.why in _ASKED_ENDS else self.why}"


class StreamSink:
    """What sees every frame recorded (the console's live pointing panel): its camera (1
    or 2), image, capture time (its camera's clock) and grab time (monotonic)."""

    def pair_frame(self, frame: TimedFrame) -> None:
        """One frame, as written."""


class StreamDriver:
    """Who decides during :func:`record_stream` (the terminal, the console, a plan)."""

    first_trial = 1

    def start(self, cameras: tuple[CameraStream, CameraStream], path: Path) -> None:
        """The source and the session file are open."""

    def next_trial(self, trial: int) -> bool:
        """Whether to stream trial ``trial``: waits for the operator (False: quit)."""
        return trial == self.first_trial

    def schedule(self, trial: int) -> Sequence[ScheduledTouch]:  # noqa: ARG002 - the default has none
        """The trial's scheduled touches (a plan's)."""
        return ()

    def duration_s(self, trial: int) -> float | None:  # noqa: ARG002 - the default has none
        """When the trial ends by itself (seconds after its start; None: the operator ends it)."""
        return None

    def events(self) -> list[StreamEvent]:
        """What the operator did since the last call (never waits)."""
        return []

    def next_point(self, trial: int) -> Vec3 | None:  # noqa: ARG002 - the default has none
        """The point a touch without one is at (the plan's next keyed point; None: none)."""
        return None

    def streaming(self, trial: int) -> None:
        """The trial's stream is open: frames flow."""

    def touched(self, touch: Touch) -> None:
        """A touch was written."""

    def refused(self, message: str) -> None:
        """An event refused (a touch with no point known): said, the stream goes on."""

    def trial_ended(self, end: TrialEnd) -> None:
        """The trial's stream is closed."""

    def offset(self, trial: int, offset: ClockOffset | None, said: str) -> None:
        """The clock offset after trial ``trial``: the session's pooled one (None: none
        yet) and what the trial gave, in words."""

    def finish(self, summary: StreamSummary) -> None:
        """The session is closed."""


@dataclass(kw_only=True)
class StreamSummary:
    """What a pair's recording holds and how it ended (:meth:`line`)."""

    path: Path
    trials: list[TrialEnd] = field(default_factory=list)
    offset: ClockOffset | None = None
    started: float = field(default_factory=time.monotonic)
    seconds: float = 0.0
    interrupted: bool = False
    stopped: str = ""  # a camera's failure that ended the recording ("": none)
    kept: bool = True

    def line(self) -> str:
        """The one summary line the command prints."""
        if not self.kept:
            return f"nothing was recorded: no session file written at {self.path}"
        frames = [sum(t.n_frames[c] for t in self.trials) for c in (0, 1)]
        dropped = [sum(t.dropped[c] for t in self.trials) for c in (0, 1)]
        touches = sum(len(t.touches) for t in self.trials)
        complete = sum(t.complete for t in self.trials)
        n = len(self.trials)
        offset = (
            "clock offset not measured (the analysis measures it)"
            if self.offset is None
            else f"clock offset {self.offset.offset_ns / 1e6:+.2f} ± "
            f"{self.offset.sigma_ns / 1e6:.2f} ms ({self.offset.method})"
        )
        ending = " (interrupted: the file is closed and valid)" if self.interrupted else ""
        if self.stopped:
            ending = f" (stopped: {self.stopped}; the file is closed and valid)"
        return (
            f"wrote {self.path}: {n} stream trial{'' if n == 1 else 's'} ({complete} complete), "
            f"frames {frames[0]} + {frames[1]} ({dropped[0]} + {dropped[1]} dropped), "
            f"{touches} touch{'' if touches == 1 else 'es'}, {offset} in "
            f"{self.seconds:.1f} s{ending}"
        )


def record_stream(
    path: str | Path,
    info: SessionInfo,
    cameras: Sequence[Camera],
    pair: PairCalibration,
    source: PairSource,
    driver: StreamDriver,
    *,
    ground: PlaneEntry | None = None,
    sink: StreamSink | None = None,
) -> StreamSummary:
    """Record a two-camera session of stream trials at ``path`` (new) from the unopened
    pair ``source``, as ``driver`` says (the module docstring). Whatever stops it leaves
    a closed, valid session; a stop before the first trial's stream leaves no file."""
    out = Path(path)
    refuse_existing(out)
    summary = StreamSummary(path=out)
    meter = OffsetMeter(pair, info.method)
    began = False
    try:
        with contextlib.ExitStack() as stack:
            stack.enter_context(meter)
            # files: every frame, in order, whatever the load (r5 F13), each detected (F3c)
            meter.lossless = source.replay()
            stack.enter_context(source)
            check_sizes(source, [camera.intrinsics for camera in cameras])
            if source.stills:
                first_frames(source)  # an empty file refused before the session begins
            info = with_clocks(info, source)
            writer = stack.enter_context(
                SessionWriter(out, info, cameras, ground=ground, pair=pair)
            )
            for warning in source.warnings:  # kept in the file, for the analysis to say
                writer.write_note(Note(text=f"warning: {warning}"))
            driver.start(source.cameras, out)
            try:
                trial = driver.first_trial - 1
                while not stops.requested() and driver.next_trial(trial + 1):
                    trial += 1
                    began = True
                    end = _stream_trial(
                        writer, trial, source, driver, meter, sink, summary,
                        lambda p: touch_refusal(info.method, pair, info.units, p),
                    )  # fmt: skip
                    driver.trial_ended(end)
                    _record_offset(writer, trial, meter, driver, summary)
                    if end.why in ("quit", "ended"):
                        break
                stops.check()
            except KeyboardInterrupt:
                summary.interrupted = True
            except SourceError as err:  # a camera stopped: its trial is closed incomplete
                summary.stopped = str(err)
                if summary.trials:  # what its frames say of the clocks is kept
                    _record_offset(writer, summary.trials[-1].trial, meter, driver, summary)
    except OSError as err:
        raise TwoposeError(f"writing {out} failed: {err.strerror or err}") from err
    except KeyboardInterrupt:  # a stop while the source opened: nothing recorded
        summary.interrupted = True
    summary.kept = began and out.exists()
    if not began:
        out.unlink(missing_ok=True)  # an empty session would only block the name
    summary.seconds = time.monotonic() - summary.started
    driver.finish(summary)
    return summary


@dataclass(kw_only=True)
class _TrialState:
    """A stream trial as it goes: camera 1's clock, the schedule, the counts."""

    trial: int
    stills: bool
    schedule: list[ScheduledTouch]
    duration_s: float | None
    start_ns: int | None = None  # camera 1's first frame's capture time
    last1_ns: int | None = None  # camera 1's latest frame's capture time
    dropped: list[int] = field(default_factory=lambda: [0, 0])
    #: Each camera's last frame's arrival (monotonic ns): one silent while the other gives
    #: frames has stopped (a file ended, a camera unplugged).
    seen_ns: list[int] = field(default_factory=lambda: [time.monotonic_ns()] * 2)
    seen_dropped: tuple[int, int] = (0, 0)
    ended: str = ""
    #: Why a point cannot be touched ("": it can; :func:`touch_refusal`).
    refuse_point: Callable[[Vec3], str] = lambda _point: ""

    def clock_ns(self, at_ns: int) -> int:
        """Camera 1's capture clock at monotonic ``at_ns`` (the module docstring)."""
        if self.stills and self.last1_ns is not None:
            return self.last1_ns
        return at_ns

    def end(self, stream: Stream, ids: Sequence[str], why: str) -> TrialEnd:
        start, last = self.start_ns, self.last1_ns
        return TrialEnd(
            trial=self.trial, why=why,
            n_frames=(stream.n_frames[ids[0]], stream.n_frames[ids[1]]),
            touches=tuple(stream.touches), missed=tuple(self.schedule),
            seconds=0.0 if start is None or last is None else (last - start) / 1e9,
            dropped=(self.dropped[0], self.dropped[1]),
        )  # fmt: skip


def _stream_trial(
    writer: SessionWriter,
    trial: int,
    source: PairSource,
    driver: StreamDriver,
    meter: OffsetMeter,
    sink: StreamSink | None,
    summary: StreamSummary,
    refuse_point: Callable[[Vec3], str],
) -> TrialEnd:
    """One stream trial, from its first frame to its end (the module docstring), counted
    in ``summary`` (also when a stop cuts it short)."""
    ids = writer.info.camera_ids
    jpeg = writer.image_format == "jpeg"
    if not source.stills:
        source.start_capture()  # frames queued between trials are not this trial's
    taken = source.take_unrecorded()
    unrecorded = taken if source.files else (0, 0)  # a camera's: not data, not said
    state = _TrialState(
        trial=trial, stills=source.timeless,
        schedule=sorted(driver.schedule(trial), key=lambda s: s.after_s),
        duration_s=driver.duration_s(trial), seen_dropped=source.dropped_by_camera,
        refuse_point=refuse_point,
    )  # fmt: skip
    meter.begin(trial)
    frames = source.frames(timeout_s=SILENT_S)  # a camera silent this long has failed
    with writer.stream(trial, window_s=WINDOW_S) as stream:
        driver.streaming(trial)
        try:
            while not state.ended:
                stops.check()
                _take_events(state, stream, driver)
                if state.ended:
                    break
                frame = next(frames, None)
                if frame is None:  # both files (folders) ended: no more pairs, a normal end
                    state.ended = "ended"
                    break
                if ran_out := source.ran_out(frame):  # the other's file or folder ended
                    raise SourceError(ran_out)
                _write_frame(state, stream, ids, frame, source, jpeg=jpeg)
                meter.add(frame)
                if sink is not None:
                    sink.pair_frame(frame)
                _due_touches(state, stream, driver)
        except (KeyboardInterrupt, SourceError) as err:
            why = str(err) if isinstance(err, SourceError) else f"interrupted ({stops.describe()})"
            stream.mark_incomplete(why)
            summary.trials.append(state.end(stream, ids, why))
            driver.trial_ended(summary.trials[-1])
            raise
    summary.trials.append(
        dataclasses.replace(state.end(stream, ids, state.ended), unrecorded=unrecorded)
    )
    return summary.trials[-1]


def _take_events(state: _TrialState, stream: Stream, driver: StreamDriver) -> None:
    """The operator's touches, end and quit since the last frame."""
    for event in driver.events():
        if event.kind in ("end", "quit"):
            state.ended = event.kind
            return
        point = event.point if event.point is not None else driver.next_point(state.trial)
        if point is None:
            driver.refused(
                "a touch needs the grid point the target is on: type it (x, y, z) before "
                "pressing Enter, or give the trial's points in a plan"
            )
            continue
        off = state.refuse_point(point)
        if off:
            driver.refused(off)
            continue
        if state.start_ns is None:
            driver.refused("not yet: the trial's first frame has not come; touch again")
            continue
        driver.touched(stream.touch(point, state.clock_ns(event.at_ns), event.how))


def _write_frame(
    state: _TrialState, stream: Stream, ids: Sequence[str], frame: TimedFrame, source: PairSource,
    *, jpeg: bool,
) -> None:  # fmt: skip
    """One frame into the stream, and what each camera dropped since the last (``jpeg``:
    the session stores JPEG, so a camera's own JPEG bytes are stored as they are)."""
    now = source.dropped_by_camera
    for c in (0, 1):
        extra = now[c] - state.seen_dropped[c]
        if extra > 0:
            stream.dropped(ids[c], extra)
            state.dropped[c] += extra
    state.seen_dropped = now
    if frame.jpeg is not None and jpeg:  # the camera's own JPEG, not decoded and encoded again
        stream.add_encoded(ids[frame.camera - 1], frame.jpeg, frame.t_capture_ns)
    else:
        stream.add_frame(ids[frame.camera - 1], frame.image, frame.t_capture_ns)
    c = frame.camera - 1
    state.seen_ns[c] = time.monotonic_ns()
    if state.seen_ns[c] - state.seen_ns[1 - c] > SILENT_S * 1e9:
        other = source.cameras[1 - c]
        raise SourceError(
            f"camera {2 - c} ({other.spec}) stopped: no frame for {SILENT_S:g} s while "
            f"camera {c + 1} gives them (no more pairs)"
        )
    if frame.camera == 1:
        state.last1_ns = frame.t_capture_ns
        if state.start_ns is None:
            state.start_ns = frame.t_capture_ns


def _due_touches(state: _TrialState, stream: Stream, driver: StreamDriver) -> None:
    """The scheduled touches camera 1's clock has passed, written at their time; the
    trial's end once its duration has passed."""
    if state.start_ns is None or state.last1_ns is None:
        return
    while state.schedule and state.start_ns + state.schedule[0].after_s * 1e9 <= state.last1_ns:
        due = state.schedule.pop(0)
        t = state.start_ns + round(due.after_s * 1e9)
        driver.touched(stream.touch(due.point, t, "schedule"))
    if state.duration_s is not None and state.last1_ns - state.start_ns >= state.duration_s * 1e9:
        state.ended = "duration"


def _record_offset(
    writer: SessionWriter,
    trial: int,
    meter: OffsetMeter,
    driver: StreamDriver,
    summary: StreamSummary,
) -> None:
    """The trial's clock offset measured, the session's pooled one recorded."""
    pooled, said = meter.end(trial)
    if pooled is not None and pooled != summary.offset:
        writer.write_clock_offset(pooled)
        summary.offset = pooled
    driver.offset(trial, summary.offset, said)
