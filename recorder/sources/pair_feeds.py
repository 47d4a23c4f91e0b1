"""One camera of a pair: its frames with their capture times (:class:`Feed`), one kind of
feed for each kind of frame source, registered by the source's type (:func:`feed_for`).

A feed is read by its own thread (:mod:`recorder.sources.pair`): :meth:`Feed.grab` waits for
the next frame and stamps it, cheaply, so that the thread keeps up with the camera;
:meth:`Feed.decode` turns what was grabbed into the image, on the reader's side. The
**capture time** of each frame is on its camera's clock, said by :attr:`Feed.clock`:

- ``"driver"``: a camera whose driver stamps its buffers (OpenCV's ``CAP_PROP_POS_MSEC`` on
  Video4Linux2 is the kernel buffer's time), checked to be on the monotonic clock and sane
  (:class:`DriverStamps`); where it is not, or the backend gives none,
- ``"monotonic at grab"``: ``time.monotonic_ns()`` right after ``grab()``, before the frame
  is retrieved or decoded;
- ``"simulated"``: a clock of the source's own, started with the pair: a video file's own
  timestamps (played at its rate), a folder of stills in file-name order at a nominal rate
  (stills have no capture time), the synthetic camera's frames at its scene's rate.

A camera is asked for MJPG (``CAP_PROP_FOURCC``) and, where it takes it, gives its JPEG
buffers undecoded (``CAP_PROP_CONVERT_RGB`` off); an MJPG video file likewise gives its
packets (``CAP_PROP_FORMAT`` -1). Files and the synthetic camera are paced like a camera: a
frame the reader is more than :data:`RING_FRAMES` intervals late for is skipped and counted
(:attr:`Feed.missed`), as a camera's driver overwrites a buffer nobody took.
"""

from __future__ import annotations

import math
import threading
import time
from abc import ABC, abstractmethod
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, Protocol

from recorder.sources.base import FrameSource, SourceInfo, open_camera, open_video
from twopose.errors import SourceError

if TYPE_CHECKING:
    from pathlib import Path

    import numpy as np
    from numpy.typing import NDArray

    Image = NDArray[np.uint8]

__all__ = [
    "CLOCKS",
    "CLOCK_DRIVER",
    "CLOCK_GRAB",
    "CLOCK_SIMULATED",
    "MAX_DRIVER_LAG_NS",
    "RING_FRAMES",
    "AskedCamera",
    "CameraFeed",
    "DriverStamps",
    "Feed",
    "Grabbed",
    "PacedFeed",
    "StillsFeed",
    "VideoFeed",
    "VideoFile",
    "mismatch",
]

CLOCK_DRIVER = "driver"
CLOCK_GRAB = "monotonic at grab"
CLOCK_SIMULATED = "simulated"
#: Where a camera's capture times come from (the session records it per camera).
CLOCKS = (CLOCK_DRIVER, CLOCK_GRAB, CLOCK_SIMULATED)
#: A driver's stamp is taken as the capture time when it is this much or less before the
#: grab (and not after it): buffers wait a few frame intervals at most in a driver's ring.
MAX_DRIVER_LAG_NS = 1_000_000_000
#: The ring of buffers a camera's driver is asked for (``CAP_PROP_BUFFERSIZE``: a second at
#: 30 fps, so that a reader thread the machine starves for a moment loses nothing; 4, OpenCV's
#: Video4Linux2 default, lost frames in the 10-minute benchmark at a load of 7 on 2 cores): a
#: paced file or the synthetic camera skips a frame the reader is later than this many
#: intervals for, as a driver overwrites a buffer nobody took.
RING_FRAMES = 30


class AskedCamera(Protocol):
    """What a camera source asks of its device (:class:`recorder.sources.registry.CameraSource`)."""

    device: int | str
    width: int
    height: int
    fps: float


class VideoFile(Protocol):
    """A video file source (:class:`recorder.sources.registry.VideoSource`)."""

    path: Path


@dataclass(frozen=True, slots=True)
class Grabbed:
    """One frame as grabbed: what :meth:`Feed.decode` makes the image of, its capture time
    (its camera's clock), the monotonic time right after the grab, and its name."""

    payload: Any
    t_capture_ns: int
    t_grab_ns: int
    name: str = ""


class Feed(ABC):
    """One camera's frames with their capture times (the module docstring)."""

    #: Where the capture times come from (:data:`CLOCKS`), and the same in words.
    clock: str = CLOCK_GRAB
    clock_note: str = ""
    #: Stills are never dropped: the reader waits for the consumer instead.
    lossless = False
    #: A recording (a video file) played at its rate: a frame it plays before a trial
    #: starts is the file's data not recorded, said as such (a camera's are not kept).
    recorded = False
    #: The stream ends (a file); a camera that stops giving frames is an error.
    finite = True
    #: A paced frame the reader is late for is taken, not skipped (a file replayed whole:
    #: :meth:`recorder.sources.pair.PairSource.replay`).
    keep_late = False
    #: The pixel format the frames come in (a camera's: ``MJPG`` where it took it).
    fourcc = ""
    info: SourceInfo

    def __init__(self) -> None:
        self.missed = 0  # frames the reader was too late for (a camera would have dropped)
        self.t0_ns = 0

    @abstractmethod
    def open(self) -> SourceInfo:
        """Open the camera or file; what it delivers."""

    def start(self, t0_ns: int) -> None:
        """The pair starts at ``t0_ns`` (monotonic): a simulated clock's zero."""
        self.t0_ns = t0_ns

    @abstractmethod
    def grab(self, stop: threading.Event) -> Grabbed | None:
        """The next frame, stamped (None: the stream ended, or ``stop`` was set)."""

    def decode(self, payload: Any) -> Image:
        """The image of a grabbed frame: a JPEG buffer decoded, an image as it is."""
        import cv2
        import numpy as np

        array = np.asarray(payload)
        if array.ndim == 3:
            return array.astype(np.uint8, copy=False)
        image = cv2.imdecode(array.reshape(-1), cv2.IMREAD_COLOR)
        if image is None:
            raise SourceError(f"{self.info.description}: a frame did not decode as JPEG")
        return np.asarray(image, dtype=np.uint8)

    def jpeg(self, payload: Any) -> bytes | None:
        """A grabbed frame's own JPEG bytes (an MJPG buffer; None: it came as an image)."""
        import numpy as np

        array = np.asarray(payload)
        if array.ndim == 3 or array.dtype != np.uint8 or array.size < 4:
            return None
        data = array.tobytes()
        return data if data[:2] == b"\xff\xd8" else None  # JPEG's start-of-image marker

    def close(self) -> None:
        """Release the camera or file."""
        return


class DriverStamps:
    """A camera's capture times from its driver's stamps, where they are sane.

    The first frame decides: its stamp is used when it is on the monotonic clock (at most
    :data:`MAX_DRIVER_LAG_NS` before the grab, never after it); else the camera's clock is
    the monotonic time at grab, and :attr:`note` says why. A later stamp that is not sane
    (not after the one before, or off the clock) is counted in :attr:`faults` and replaced
    by the grab time less the last sane lag, so that one camera keeps one clock.
    """

    def __init__(self) -> None:
        self.clock: str | None = None
        self.note = ""
        self.faults = 0
        self._lag_ns = 0
        self._last_ns: int | None = None

    def time(self, stamp_ms: float, t_grab_ns: int) -> int:
        """The capture time of a frame whose driver stamp is ``stamp_ms`` (milliseconds,
        as OpenCV gives it; 0 or NaN: none) and that was grabbed at ``t_grab_ns``."""
        stamp_ns = round(stamp_ms * 1e6) if math.isfinite(stamp_ms) and stamp_ms > 0 else None
        sane = (
            stamp_ns is not None
            and 0 <= t_grab_ns - stamp_ns <= MAX_DRIVER_LAG_NS
            and (self._last_ns is None or stamp_ns > self._last_ns)
        )
        if self.clock is None:
            self._decide(stamp_ns, t_grab_ns, sane=sane)
        if self.clock == CLOCK_DRIVER and sane and stamp_ns is not None:
            self._lag_ns = t_grab_ns - stamp_ns
            t = stamp_ns
        elif self.clock == CLOCK_DRIVER:
            self.faults += 1
            t = t_grab_ns - self._lag_ns
        else:
            t = t_grab_ns
        if self._last_ns is not None:
            t = max(t, self._last_ns + 1)
        self._last_ns = t
        return t

    def _decide(self, stamp_ns: int | None, t_grab_ns: int, *, sane: bool) -> None:
        if sane:
            self.clock = CLOCK_DRIVER
            self.note = "the driver's buffer stamp (CAP_PROP_POS_MSEC), on the monotonic clock"
            return
        self.clock = CLOCK_GRAB
        if stamp_ns is None:
            why = "the backend gives no buffer stamp"
        else:
            why = (
                f"the driver's stamp is {(t_grab_ns - stamp_ns) / 1e9:+.3g} s from the grab, "
                "not on the monotonic clock"
            )
        self.note = f"the monotonic clock right after grab(), before decoding ({why})"


def _fourcc_text(value: float) -> str:
    code = int(value)
    text = "".join(chr((code >> (8 * k)) & 0xFF) for k in range(4))
    return text if text.isprintable() and text.strip() else ""


class CameraFeed(Feed):
    """A camera (its source's device, size and rate asked: :class:`AskedCamera`)."""

    finite = False

    def __init__(self, source: AskedCamera) -> None:
        super().__init__()
        self.source = source
        self.stamps = DriverStamps()
        self._cap: Any = None

    def open(self) -> SourceInfo:
        import cv2

        s = self.source
        cap, self.info = open_camera(s.device, s.width, s.height, s.fps, fourcc="MJPG")
        cap.set(cv2.CAP_PROP_BUFFERSIZE, RING_FRAMES)  # a driver without it keeps its own
        self.fourcc = _fourcc_text(cap.get(cv2.CAP_PROP_FOURCC))
        if self.fourcc == "MJPG":  # the JPEG buffers as they come: decoded off this thread
            cap.set(cv2.CAP_PROP_CONVERT_RGB, 0)
        self._cap = cap
        return self.info

    def grab(self, stop: threading.Event) -> Grabbed | None:
        import cv2

        if stop.is_set() or not self._cap.grab():
            return None
        t_grab = time.monotonic_ns()
        t = self.stamps.time(float(self._cap.get(cv2.CAP_PROP_POS_MSEC)), t_grab)
        self.clock, self.clock_note = self.stamps.clock or CLOCK_GRAB, self.stamps.note
        ok, payload = self._cap.retrieve()
        if not ok or payload is None:
            return None
        return Grabbed(payload, t, t_grab)

    def close(self) -> None:
        if self._cap is not None:
            self._cap.release()


class _Paced(Feed):
    """A file or the synthetic camera: frame k is due at its own time from the pair's start."""

    clock = CLOCK_SIMULATED

    def _due(self, t_ns: int, interval_ns: int, stop: threading.Event) -> bool | None:
        """Wait until ``t_ns`` after the start; False: too late (skip it); None: stopped."""
        due = self.t0_ns + t_ns
        late = time.monotonic_ns() - due
        if late < 0:
            return None if stop.wait(-late / 1e9) else True
        return self.keep_late or late <= RING_FRAMES * interval_ns


class VideoFeed(_Paced):
    """A video file played at its rate, each frame at its own timestamp (its frame rate's
    where a timestamp does not increase)."""

    recorded = True

    def __init__(self, source: VideoFile) -> None:
        super().__init__()
        self.path = source.path
        self._cap: Any = None
        self._pts_ns = -1

    def open(self) -> SourceInfo:
        import cv2

        cap, self.info = open_video(self.path)
        self.fourcc = _fourcc_text(cap.get(cv2.CAP_PROP_FOURCC))
        if self.fourcc == "MJPG":  # each packet a JPEG: grabbed undecoded
            cap.set(cv2.CAP_PROP_FORMAT, -1)
        self._cap = cap
        self.clock_note = (
            f"the file's own timestamps, played at its rate ({self.info.fps:g} fps) from the "
            "pair's start"
        )
        return self.info

    def grab(self, stop: threading.Event) -> Grabbed | None:
        import cv2

        interval = round(1e9 / self.info.fps)
        while not stop.is_set() and self._cap.grab():
            pts_ms = float(self._cap.get(cv2.CAP_PROP_POS_MSEC))
            pts = round(pts_ms * 1e6) if math.isfinite(pts_ms) else -1
            self._pts_ns = pts if pts > self._pts_ns else self._pts_ns + interval
            due = self._due(self._pts_ns, interval, stop)
            if due is None:
                return None
            if not due:
                self.missed += 1
                continue
            ok, payload = self._cap.retrieve()
            if not ok or payload is None:
                return None
            return Grabbed(payload, self.t0_ns + self._pts_ns, time.monotonic_ns())
        return None

    def close(self) -> None:
        if self._cap is not None:
            self._cap.release()


class PacedFeed(_Paced):
    """A source that renders its frames (the synthetic camera), paced at its rate: frame k
    taken at k frame intervals from the pair's start, on that simulated clock."""

    def __init__(self, source: FrameSource) -> None:
        super().__init__()
        self.source = source
        self._k = 0

    def open(self) -> SourceInfo:
        self.info = self.source.open()
        self.clock_note = (
            f"{self.info.description}'s frames at its rate ({self.info.fps:g} fps) from the "
            "pair's start"
        )
        return self.info

    def grab(self, stop: threading.Event) -> Grabbed | None:
        interval = round(1e9 / self.info.fps)
        while not stop.is_set():
            t = self._k * interval
            self._k += 1
            due = self._due(t, interval, stop)
            if due is None:
                return None
            if due:
                return Grabbed(self.source.read(), self.t0_ns + t, time.monotonic_ns())
            self.missed += 1
        return None

    def close(self) -> None:
        self.source.close()


class StillsFeed(Feed):
    """A folder of stills: in file-name order, each at a nominal frame interval from the
    pair's start (stills have no capture time); never dropped, and decoded as read (their
    time does not depend on when)."""

    clock = CLOCK_SIMULATED
    lossless = True

    def __init__(self, source: FrameSource) -> None:
        super().__init__()
        self.source = source
        self._k = 0
        self.ended_by = ""  # why the folder ended ("no more images ...")

    def open(self) -> SourceInfo:
        self.info = self.source.open()
        self.clock_note = (
            f"stills have no capture time: file-name order at a nominal {self.info.fps:g} fps"
        )
        return self.info

    def grab(self, stop: threading.Event) -> Grabbed | None:
        if stop.is_set():
            return None
        try:
            image = self.source.read()
        except SourceError as err:  # the folder ran out (or a still is unreadable): said
            self.ended_by = str(err)
            return None
        t = self.t0_ns + round(self._k * 1e9 / self.info.fps)
        name = self.source.frame_name(self._k)
        self._k += 1
        return Grabbed(image, t, time.monotonic_ns(), name)

    def close(self) -> None:
        self.source.close()


def mismatch(a: SourceInfo, b: SourceInfo) -> tuple[str, ...]:
    """Two cameras' sizes and rates compared (camera 1's ``a``, camera 2's ``b``): what
    differs, said."""
    said = []
    if (a.width, a.height) != (b.width, b.height):
        said.append(
            f"camera 1 gives {a.width}x{a.height} frames, camera 2 {b.width}x{b.height}: "
            "each camera is calibrated at its own size"
        )
    if abs(a.fps - b.fps) > 0.01 * max(a.fps, b.fps):
        said.append(
            f"camera 1 runs at {a.fps:g} fps, camera 2 at {b.fps:g} fps: pairs come at the "
            "slower rate, within half the faster one's frame interval"
        )
    return tuple(said)
