"""Two cameras at once: ``--source pair:A,B``, any two one-camera sources the registry knows
(:data:`recorder.sources.registry.SOURCE_KINDS`), camera 1 first.

``A`` and ``B`` are written as the operator writes one source (``camera:0``,
``video:a.mp4``, ``images:photos/left*.jpg``, ``synthetic``), colons and all, separated by
a comma: ``pair:camera:0,camera:1``. A source whose text holds a comma (a path) is put in
double quotes, a quote inside it doubled, as in a CSV file (the text is read by Python's
``csv`` module): ``pair:"video:take 1,2.mp4",video:b.mp4`` (inside the shell's single
quotes). :func:`recorder.sources.registry.pair_spec` writes it so.

:class:`PairSource` reads each camera on its own thread (:mod:`recorder.sources.pair_feeds`: grab
as fast as the camera gives, stamp each frame with its capture time, decode on the reader's
side) into a bounded queue that holds :data:`QUEUE_S` seconds of the camera's frames and at
most :data:`QUEUE_BYTES` bytes of them (10 s of 640x480 MJPG at 30 fps is ~27 MB; of
undecoded BGR frames, ~280 MB, so the bytes bind first at ~9 s), so that a consumer the
machine stalls for a few seconds loses nothing. Past the bound a camera's oldest frame is
dropped, counted (:attr:`PairSource.dropped_by_camera`) and said
(:meth:`PairSource.drops_said`: each time a queue overflows, how far behind the consumer
was); the camera is never held up (a folder of stills is never dropped: its thread waits
instead). It gives each camera's frames with their
capture times as they come (two folders of stills, which have no time of their own:
strictly in capture order, each camera's next frame waited for, so that how fast each
thread reads never decides which frames a trial holds; :meth:`PairSource.frames`, not
paired: pairing is
:mod:`twopose.pair.pairing`'s), or pairs made live by that same policy
(:meth:`PairSource.pairs`). A stop of the recording (Ctrl-C, SIGTERM:
:mod:`recorder.procedure.stops`)
ends both threads at once and raises ``KeyboardInterrupt`` in the reader.

(Near 600 lines: one concern, two cameras read at once: the readers' threads and their
bounded queues, and the consumer's side that takes, decodes and pairs their frames; each
camera's feed is :mod:`recorder.sources.pair_feeds`'.)
"""

from __future__ import annotations

import dataclasses
import math
import threading
import time
from collections import deque
from collections.abc import Iterator
from dataclasses import dataclass
from typing import TYPE_CHECKING

from recorder.procedure import stops
from recorder.sources.base import FrameSource, SourceInfo, pair_spec
from recorder.sources.pair_feeds import Feed, Grabbed, mismatch
from twopose.errors import SourceError

if TYPE_CHECKING:
    import numpy as np
    from numpy.typing import NDArray

    Image = NDArray[np.uint8]

__all__ = [
    "QUEUE_BYTES",
    "QUEUE_S",
    "RAN_OUT_INTERVALS",
    "CameraStream",
    "FramePair",
    "PairSource",
    "QueueBound",
    "TimedFrame",
]

#: How long each camera's queue holds frames the consumer has not taken (its frame rate
#: times this, in frames): a consumer held up by a disk's flush or a busy machine for a few
#: seconds loses nothing (the 10-minute benchmark saw stalls of 1.25 s at a load of 11 on 2
#: cores; a one-second queue then dropped 42 of 18000 pairs).
QUEUE_S = 10.0
#: And at most this many bytes of frames per camera (MJPG frames are ~90 kB each, undecoded
#: BGR ones 921 kB at 640x480): whichever of the two bounds is reached first binds.
QUEUE_BYTES = 256 * 2**20
#: How many overflows of a queue are said one by one (then counted only).
_SAID_MAX = 20
#: A file or folder whose last frame lies more than this many of its frame intervals
#: before the other camera's frame has ran out (:meth:`PairSource.ran_out`): the pairing's
#: slop is half an interval; two files of one length that end together are not cut.
RAN_OUT_INTERVALS = 2.0
_POLL_S = 0.05  # how often a wait looks whether the recording is to stop
_JOIN_S = 2.0  # how long closing waits for both reader threads, together


@dataclass(frozen=True, slots=True)
class TimedFrame:
    """One camera's frame: ``camera`` 1 or 2, its number ``index`` among the frames that
    camera gave (from 0; a frame dropped leaves a gap), its capture time ``t_capture_ns``
    on its camera's clock, the monotonic time ``t_grab_ns`` right after it was grabbed (its
    arrival), the BGR ``image`` and its ``name`` (a still's file name); ``jpeg`` the
    camera's own JPEG bytes it was decoded from (an MJPG camera's or file's; None: it came
    decoded), which a recording stores as they are instead of encoding the image again."""

    camera: int
    index: int
    t_capture_ns: int
    t_grab_ns: int
    image: Image
    name: str
    jpeg: bytes | None = None


@dataclass(frozen=True, slots=True)
class FramePair:
    """Camera 1's frame and camera 2's, paired by capture time: ``skew_ns`` is camera 2's
    capture time on camera 1's clock minus camera 1's."""

    first: TimedFrame
    second: TimedFrame
    skew_ns: int


@dataclass(frozen=True, kw_only=True)
class CameraStream:
    """What one camera of the pair delivers: its source text, size and rate, the pixel
    format it gives (``MJPG`` where it took it), its clock (``driver``, ``monotonic at
    grab``, ``simulated``: :data:`recorder.sources.pair_feeds.CLOCKS`) and the same in words."""

    spec: str
    info: SourceInfo
    fourcc: str
    clock: str
    clock_note: str
    #: What is doubtful about its frames ("": nothing), said as a warning with it.
    warning: str = ""

    def text(self) -> str:
        """The camera as the operator is told it."""
        i = self.info
        fmt = f", {self.fourcc}" if self.fourcc else ""
        warn = f"; warning: {self.warning}" if self.warning else ""
        return (
            f"{self.spec}: {i.width}x{i.height} at {i.fps:g} fps{fmt}; clock: "
            f"{self.clock_note}{warn}"
        )


class _Reader:
    """One camera: its feed, its reader thread and its bounded queue."""

    def __init__(self, camera: int, spec: str, feed: Feed, bound: QueueBound) -> None:
        self.camera, self.spec, self.feed = camera, spec, feed
        self.queue: deque[tuple[int, Grabbed]] = deque()
        self.bound = bound
        self.limit = bound.frames or 1  # set at open from the camera's rate
        self.bytes = 0  # of the frames queued
        self.dropped = 0  # taken from the camera, dropped because the reader was slow
        self.overflows = 0  # times the queue filled and began dropping
        self.deepest = (0, 0)  # the most frames (and their bytes) it held
        self.said: list[str] = []  # the first overflows, in words
        self._dropping = False  # the last frame put dropped one: the same overflow
        self.grabbed = 0
        self.ended = False  # the thread is done (the stream ended, failed or was stopped)
        self.error: SourceError | None = None
        self.last_ns = time.monotonic_ns()
        self.taken_ns: int | None = None  # the capture time of the frame last taken
        self.thread: threading.Thread | None = None

    def run(self, cond: threading.Condition, stop: threading.Event) -> None:
        try:
            while not stop.is_set():
                grabbed = self.feed.grab(stop)
                if grabbed is None:
                    if not self.feed.finite and not stop.is_set():
                        self.error = SourceError(
                            f"camera {self.camera} ({self.spec}) stopped delivering frames "
                            "(unplugged?)"
                        )
                    return
                self._put(cond, stop, grabbed)
        except KeyboardInterrupt:  # the recording is to stop (a source's own stops.check)
            return
        except SourceError as err:
            self.error = SourceError(f"camera {self.camera} ({self.spec}): {err}")
        except Exception as err:  # a backend's failure: said by the reader, not a traceback
            self.error = SourceError(f"camera {self.camera} ({self.spec}) failed: {err!r}")
        finally:
            with cond:
                self.ended = True
                cond.notify_all()

    def set_rate(self, fps: float) -> None:
        """The queue's bound in frames, from the camera's rate (:data:`QUEUE_S` seconds)."""
        if not self.bound.frames:
            self.limit = max(1, math.ceil(self.bound.seconds * fps))

    def _full(self, size: int) -> bool:
        return bool(self.queue) and (
            len(self.queue) >= self.limit or self.bytes + size > self.bound.bytes
        )

    def _put(self, cond: threading.Condition, stop: threading.Event, grabbed: Grabbed) -> None:
        size = _nbytes(grabbed.payload)
        with cond:
            while self.feed.lossless and self._full(size) and not stop.is_set():
                cond.wait(_POLL_S)  # stills wait for the reader; a camera never does
            dropped_now, oldest_ns = False, self.queue[0][1].t_capture_ns if self.queue else 0
            while self._full(size):
                self.bytes -= _nbytes(self.queue.popleft()[1].payload)
                self.dropped += 1
                dropped_now = True
            if dropped_now and not self._dropping:
                self._say_overflow((grabbed.t_capture_ns - oldest_ns) / 1e9)
            self._dropping = dropped_now
            self.queue.append((self.grabbed, grabbed))
            self.bytes += size
            self.deepest = max(self.deepest, (len(self.queue), self.bytes))
            self.grabbed += 1
            self.last_ns = time.monotonic_ns()
            cond.notify_all()

    def _say_overflow(self, behind_s: float) -> None:
        """An overflow begins, the consumer ``behind_s`` behind the camera: said (the first
        :data:`_SAID_MAX`), always counted."""
        self.overflows += 1
        if self.overflows > _SAID_MAX:
            return
        self.said.append(
            f"camera {self.camera} ({self.spec}): the consumer fell {behind_s:.1f} s behind, "
            f"past the queue's bound ({self.limit} frames, {self.bytes / 1e6:.1f} MB queued of "
            f"{self.bound.bytes / 1e6:.0f} MB): its oldest frames dropped (frame "
            f"{self.grabbed - len(self.queue)} the first of them), counted"
        )

    def drop_lines(self) -> list[str]:
        """Its overflows in words (the first :data:`_SAID_MAX`, then how many more)."""
        more = self.overflows - len(self.said)
        extra = [f"camera {self.camera} ({self.spec}): {more} overflow(s) more"] if more else []
        return [*self.said, *extra]

    def take(self) -> tuple[int, Grabbed]:
        """The oldest queued frame, taken by the consumer (the condition held)."""
        index, grabbed = self.queue.popleft()
        self.bytes -= _nbytes(grabbed.payload)
        return index, grabbed

    @property
    def drained(self) -> bool:
        return self.ended and not self.queue


@dataclass(frozen=True)
class QueueBound:
    """A camera's queue's bound: ``seconds`` of its frames (at its rate), at most
    ``bytes`` of them; ``frames`` (> 0) a count instead of the seconds (tests)."""

    seconds: float = QUEUE_S
    bytes: int = QUEUE_BYTES
    frames: int = 0

    def __post_init__(self) -> None:
        if not (self.seconds > 0 and self.bytes > 0 and self.frames >= 0):
            raise SourceError(
                f"a camera's queue holds more than 0 s and 0 bytes, got {self.seconds} s, "
                f"{self.bytes} bytes, {self.frames} frames"
            )


def _nbytes(payload: object) -> int:
    """A grabbed frame's size in bytes (a JPEG buffer's, or an image's)."""
    if isinstance(payload, bytes | bytearray):
        return len(payload)
    return int(getattr(payload, "nbytes", 0))


class PairSource(FrameSource):
    """Two cameras' frames with their capture times (the module docstring).

    Opened from ``pair:A,B`` (:func:`recorder.sources.registry.open_source` refuses it: a
    one-camera command takes one camera) by :func:`recorder.sources.registry.open_from`, or by
    :func:`recorder.sources.registry.open_pair` ("camera:0", "camera:1"), which give it each
    camera's :class:`~recorder.sources.pair_feeds.Feed` and source text. :meth:`read` gives the
    next frame of either camera (:meth:`read_frame` with its camera and capture time).
    """

    def __init__(
        self,
        feeds: tuple[Feed, Feed],
        specs: tuple[str, str],
        *,
        bound: QueueBound | None = None,
        note2: str = "",
    ) -> None:
        self.specs = specs
        self.note2 = note2  # a warning about camera 2's frames (CameraStream.warning)
        self.bound = bound or QueueBound()
        self._readers = tuple(
            _Reader(n, spec, feed, self.bound)
            for n, (spec, feed) in enumerate(zip(self.specs, feeds, strict=True), start=1)
        )
        self.stills = all(f.lossless for f in feeds)
        #: Stills alone, or files replayed whole: frames without the operator's time (a key
        #: or a button is camera 1's frame last recorded, the one the operator sees).
        self.timeless = self.stills
        #: A video file among the feeds: its frames played before a trial are counted.
        self.files = any(f.recorded for f in feeds)
        #: Each camera's frames taken and not recorded since :meth:`take_unrecorded`
        #: (queued before a capture started, or read to learn its clock).
        self.unrecorded = [0, 0]
        self.warnings: tuple[str, ...] = ()
        #: Why :meth:`pairs` ended before both streams did ("": it did not).
        self.ended_early = ""
        self._cond = threading.Condition()
        self._stop = threading.Event()
        self._opened = False

    def bound_to(self, bound: QueueBound) -> None:
        """Each camera's queue bounded by ``bound`` instead (before :meth:`open`): a
        consumer that wants fresh frames over whole ones (a live board search) keeps less."""
        if self._opened:
            raise SourceError("a pair source's queues are bounded before it is opened")
        self.bound = bound
        for reader in self._readers:
            reader.bound, reader.limit = bound, bound.frames or 1

    def replay(self) -> bool:
        """Files and folders alone (before :meth:`open`): every frame of both read in
        order, none skipped nor dropped, each camera's next frame waited for, as a
        folder's stills are (:attr:`stills` then True), so that the same files give the
        same frames whatever the machine's load; False (nothing changed) with a camera."""
        if self._opened:
            raise SourceError("a pair source is replayed whole from before it is opened")
        feeds = [r.feed for r in self._readers]
        if not all(f.recorded or f.lossless for f in feeds):
            return False
        for feed in feeds:
            feed.lossless = feed.keep_late = True
        # A replay runs at the machine's pace, its frames stamped on the files' clock
        # from when they opened: a touch stamped as it came landed seconds from the frame
        # on the page (a new user's r7 K6: a button 1.0 s after start, 4.97 s into the
        # trial's frames, past their end), so a touch takes the frame last recorded.
        self.stills = self.timeless = True
        return True

    def open(self) -> SourceInfo:
        opened: list[_Reader] = []
        try:
            for reader in self._readers:
                reader.set_rate(reader.feed.open().fps)
                opened.append(reader)
        except BaseException:
            for reader in opened:
                reader.feed.close()
            raise
        one, two = (r.feed.info for r in self._readers)
        self.warnings = (*((self.note2,) if self.note2 else ()), *mismatch(one, two))
        first = self._readers[0].feed.info
        self.info = dataclasses.replace(first, description=pair_spec(*self.specs))
        stop = stops.active()
        if stop is not None:
            stop.on_request(self._stop.set)
        t0 = time.monotonic_ns() + 20_000_000  # both threads running before the first is due
        for reader in self._readers:
            reader.feed.start(t0)
            reader.last_ns = time.monotonic_ns()
            reader.thread = threading.Thread(
                target=reader.run,
                args=(self._cond, self._stop),
                name=f"pair camera {reader.camera}",
                daemon=True,
            )
            reader.thread.start()
        self._opened = True
        return self.info

    @property
    def cameras(self) -> tuple[CameraStream, CameraStream]:
        """What each camera delivers (its clock as its first frame decided it)."""
        one, two = (
            CameraStream(
                spec=r.spec,
                info=r.feed.info,
                fourcc=r.feed.fourcc,
                clock=r.feed.clock,
                clock_note=r.feed.clock_note,
                warning=self.note2 if r.camera == 2 else "",
            )
            for r in self._readers
        )
        return one, two

    @property
    def dropped_by_camera(self) -> tuple[int, int]:
        """Each camera's frames dropped: the reader was too slow (the oldest queued went),
        or too late for the camera itself (a paced file's or the synthetic camera's)."""
        one, two = (r.dropped + r.feed.missed for r in self._readers)
        return one, two

    @property
    def grabbed_by_camera(self) -> tuple[int, int]:
        """Each camera's frames taken so far (a folder's: its stills read)."""
        one, two = (r.grabbed for r in self._readers)
        return one, two

    @property
    def ended_by_camera(self) -> tuple[bool, bool]:
        """Whether each camera's stream has ended (its frames may still be queued)."""
        one, two = (r.ended for r in self._readers)
        return one, two

    @property
    def late_by_camera(self) -> tuple[int, int]:
        """Of :attr:`dropped_by_camera`, the frames a reader thread was too late for (a
        paced file's or the synthetic camera's; a camera's driver drops those unseen)."""
        one, two = (r.feed.missed for r in self._readers)
        return one, two

    @property
    def dropped(self) -> int:
        """Both cameras' frames dropped."""
        return sum(self.dropped_by_camera)

    @dropped.setter
    def dropped(self, _value: int) -> None:
        return  # counted per camera (dropped_by_camera)

    @property
    def deepest_by_camera(self) -> tuple[tuple[int, int], tuple[int, int]]:
        """Each camera's queue at its deepest: (frames, bytes) it held, against the bound
        (:attr:`bound`): how far the consumer fell behind, and the margin left."""
        one, two = (r.deepest for r in self._readers)
        return one, two

    def drops_said(self) -> list[str]:
        """Each time a camera's queue overflowed (the consumer fell behind past its bound,
        :class:`QueueBound`), in words: how far behind, what was dropped; empty when none."""
        return [line for r in self._readers for line in r.drop_lines()]

    def ended_by(self) -> list[str]:
        """Why a camera's stream ended, where it said (a folder that ran out)."""
        return [
            f"camera {r.camera} ({r.spec}): {why}"
            for r in self._readers
            if r.drained and (why := getattr(r.feed, "ended_by", ""))
        ]

    def ran_out(self, frame: TimedFrame) -> str:
        """Why ``frame`` has no partner left: the other camera's file or folder ended
        (read to its end, no failure) more than :data:`RAN_OUT_INTERVALS` of its frame
        intervals before ``frame``'s capture, on the stream's clock ("": it did not). A
        finite source knows its end: no wall time is waited (a folder is read faster
        than its nominal rate)."""
        other = self._readers[2 - frame.camera]
        if not (other.drained and other.error is None and other.feed.finite):
            return ""
        last = other.taken_ns
        if last is not None and frame.t_capture_ns - last <= RAN_OUT_INTERVALS * 1e9 / (
            other.feed.info.fps or 1.0
        ):
            return ""
        what = "file" if other.feed.recorded else "folder"
        why = getattr(other.feed, "ended_by", "") or f"its {what} ended"
        when = (
            "gave no frame"
            if last is None
            else f"gave its last frame {(frame.t_capture_ns - last) / 1e9:.2f} s earlier"
        )
        return (
            f"camera {other.camera} ({other.spec}) ran out ({why}): its {what} {when} "
            f"while camera {frame.camera} gives them (no more pairs)"
        )

    def read(self, timeout_s: float = 2.0) -> Image:
        """The next frame of either camera (:meth:`read_frame`'s image)."""
        return self.read_frame(timeout_s).image

    def read_frame(self, timeout_s: float = 2.0) -> TimedFrame:
        """The next frame of either camera, the earlier captured first among those
        queued; SourceError when both streams ended, a camera failed or was silent for
        ``timeout_s``; KeyboardInterrupt when the recording is to stop."""
        frame = self._next(timeout_s)
        if frame is None:
            said = "; ".join(self.ended_by())
            raise SourceError(
                f"{self.info.description} has no more frames" + (f" ({said})" if said else "")
            )
        return frame

    def frames(self, timeout_s: float = 2.0) -> Iterator[TimedFrame]:
        """Each camera's frames as they come, until both streams end."""
        while (frame := self._next(timeout_s)) is not None:
            yield frame

    def pairs(
        self, *, offset_ns: int = 0, slop_ns: int | None = None, timeout_s: float = 2.0
    ) -> Iterator[FramePair]:
        """Pairs by capture time as they become final (:mod:`twopose.pair.live_pairing`:
        :func:`twopose.pair.pairing.pair_captures`' pairs, on each camera's fitted clock),
        until no pair can come: both
        streams ended, or one did and the other's frames passed its last by the slop
        (:attr:`ended_early` then says which; the other file is not played to its end).

        ``offset_ns`` camera 2's clock minus camera 1's; ``slop_ns`` the largest |skew| of
        a pair (default: half the faster camera's frame interval).
        """
        from twopose.pair.live_pairing import LivePairing

        if slop_ns is None:
            fastest = max(r.feed.info.fps for r in self._readers)
            slop_ns = round(0.5e9 / fastest)
        live: LivePairing[TimedFrame] = LivePairing(
            slop_ns=slop_ns, offset_ns=offset_ns, window=max(64, 4 * self._readers[0].limit)
        )
        told = [False, False]
        last_ns = [-(2**62), -(2**62)]  # each camera's last capture, on camera 1's clock
        while True:
            frame = self._next(timeout_s)
            made = [] if frame is None else live.add(frame.camera, frame.t_capture_ns, frame)
            if frame is not None:
                c = frame.camera - 1
                last_ns[c] = frame.t_capture_ns - (offset_ns if c else 0)
                if told[1 - c] and last_ns[c] > last_ns[1 - c] + slop_ns:
                    r = self._readers[1 - c]
                    self.ended_early = f"camera {r.camera} ({r.spec}) ended: no more pairs"
                    frame = None  # this camera's later frames have no partner left
            for n, reader in enumerate(self._readers):
                if not told[n] and (reader.drained or frame is None):
                    told[n] = True
                    made += live.end(n + 1)
            yield from (FramePair(p.first, p.second, p.skew_ns) for p in made)
            if frame is None:
                return

    def _next(self, timeout_s: float) -> TimedFrame | None:
        """The next queued frame (None: both streams ended), decoded here."""
        if not self._opened:
            raise SourceError("the pair source is not open (use it as a context manager)")
        with self._cond:
            while True:
                stops.check()  # the recording is to stop: KeyboardInterrupt here
                if self._stop.is_set():
                    raise SourceError(f"{self.info.description} was closed")
                ready = [r for r in self._readers if r.queue]
                # Stills: only once each camera has its next frame (or ended), so that a
                # thread read faster (a loaded machine) never runs its camera ahead.
                merged = not self.stills or all(r.queue or r.ended for r in self._readers)
                if ready and merged:
                    reader = min(ready, key=lambda r: r.queue[0][1].t_capture_ns)
                    index, grabbed = reader.take()
                    reader.taken_ns = grabbed.t_capture_ns
                    self._cond.notify_all()  # a folder's thread may wait for room
                    break
                self._raise_failed(timeout_s)
                if all(r.drained for r in self._readers):
                    return None
                self._cond.wait(_POLL_S)
        image = reader.feed.decode(grabbed.payload)
        name = grabbed.name or f"camera {reader.camera} frame {index + 1}"
        return TimedFrame(
            reader.camera, index, grabbed.t_capture_ns, grabbed.t_grab_ns, image, name,
            reader.feed.jpeg(grabbed.payload),
        )  # fmt: skip

    def _raise_failed(self, timeout_s: float) -> None:
        """A camera that failed, or that is silent (nothing queued for ``timeout_s``)."""
        now = time.monotonic_ns()
        for r in self._readers:
            if r.drained and r.error is not None:
                raise r.error
            if not r.ended and not r.queue and now - r.last_ns > timeout_s * 1e9:
                raise SourceError(f"camera {r.camera} ({r.spec}) sent no frame for {timeout_s:g} s")

    def start_capture(self) -> None:
        """Frames queued before now are stale: dropped as dropped frames are not, counted
        in :attr:`unrecorded` (a video file's are its data, said)."""
        with self._cond:
            for r in self._readers:
                self.unrecorded[r.camera - 1] += len(r.queue)
                r.queue.clear()
                r.bytes = 0
            self._cond.notify_all()

    def take_unrecorded(self) -> tuple[int, int]:
        """Each camera's frames not recorded since the last call (then counted afresh)."""
        taken = (self.unrecorded[0], self.unrecorded[1])
        self.unrecorded = [0, 0]
        return taken

    def close(self) -> None:
        """Stop both reader threads (at most :data:`_JOIN_S` together) and release the
        cameras; a thread stuck in its driver keeps its camera until the process ends."""
        self._stop.set()
        deadline = time.monotonic() + _JOIN_S
        for r in self._readers:
            if r.thread is not None:
                r.thread.join(max(0.0, deadline - time.monotonic()))
            if r.thread is None or not r.thread.is_alive():
                r.feed.close()
