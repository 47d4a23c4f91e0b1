"""The writer's windows of frames: a capture at a typed pose, and a two-camera stream.

:class:`Capture` (:meth:`SessionWriter.capture`): one camera's frames at one typed pose,
then its :class:`~twopose.format.entries.CaptureWindow`. :class:`Stream`
(:meth:`SessionWriter.stream`, format 1.6): a stream trial of a two-camera session, both
cameras' frames each with its capture time, and the touches marked during it; its frames
in windows of a second or so (:class:`~twopose.format.entries.StreamWindow`), each
announced ``open`` when it begins and closed, flushed and synced to disk when the next
begins, so that a crash (kill -9, a power cut) loses at most the open window, and
``recover`` knows the trial of the frames it salvages from it.
"""

from __future__ import annotations

import math
from collections.abc import Iterable, Sequence
from types import TracebackType
from typing import Protocol, Self

import numpy as np
from numpy.typing import NDArray

from twopose.errors import InputValueError
from twopose.format.entries import CaptureWindow, SessionInfo, StreamWindow, Touch, TypedEntry
from twopose.format.stream_entries import TouchMark, WindowStatus
from twopose.values.checks import index


class _Writer(Protocol):
    """What a window uses of its :class:`~twopose.format.writer.SessionWriter`.

    The writer imports this module: a protocol, not an import, keeps the two apart.
    """

    info: SessionInfo

    @property
    def is_open(self) -> bool: ...

    @property
    def last_ns(self) -> int: ...

    def time(self, log_time_ns: int | None) -> int: ...

    def encode_image(self, image_bgr: NDArray[np.uint8]) -> bytes: ...

    def write_image(
        self, camera_id: str, data: bytes, log_time_ns: int, capture_ns: int | None = None
    ) -> int: ...

    def write_entry(self, entry: TypedEntry, log_time_ns: int | None = None) -> None: ...

    def write_entries(
        self, entries: Iterable[TypedEntry], log_time_ns: int | None = None, *, sync: bool = False
    ) -> None: ...

    def _check_camera(self, camera_id: str) -> None: ...

    def _begin_capture(self, capture: Capture | Stream | None) -> None: ...


__all__ = ["Capture", "Stream"]


def _stop_reason(exc_type: type[BaseException] | None, exc: BaseException | None) -> str:
    """Why an error ended a window ("": none did)."""
    if isinstance(exc, KeyboardInterrupt):
        return "interrupted (Ctrl-C) during the capture"
    if exc is not None:
        return f"{exc_type.__name__ if exc_type else 'error'}: {exc}"
    return ""


class Capture:
    """One capture window: its frames, then its :class:`CaptureWindow` entry.

    One capture window (see :meth:`SessionWriter.capture`): its frames, then on exit its
    :class:`CaptureWindow` entry (``incomplete`` with the reason after an error).
    """

    def __init__(
        self,
        writer: _Writer,
        trial: int,
        pose: int,
        camera_id: str,
        capture: int | None = None,
    ) -> None:
        self._writer = writer
        self.trial = trial
        self.pose = pose
        self.camera_id = camera_id
        self.number = capture
        self.start_ns: int | None = None
        self.end_ns: int | None = None
        self.n_frames = 0
        self.dropped_frames = 0
        self._incomplete_reason = ""

    def __enter__(self) -> Self:
        """Begin the capture (one at a time per writer)."""
        self._writer._begin_capture(self)
        return self

    def add_frame(
        self,
        image_bgr: NDArray[np.uint8],
        log_time_ns: int | None = None,
        *,
        capture_ns: int | None = None,
    ) -> int:
        """Encode and write one frame; returns its sequence number on the image topic.

        ``capture_ns``: when the frame was taken (the grab), on the camera's clock; None:
        its write time.
        """
        return self.add_encoded(
            self._writer.encode_image(image_bgr), log_time_ns, capture_ns=capture_ns
        )

    def add_encoded(
        self, data: bytes, log_time_ns: int | None = None, *, capture_ns: int | None = None
    ) -> int:
        """Write one already-encoded frame in the session's image format.

        ``capture_ns``: :meth:`add_frame`'s.
        """
        t = self._writer.time(log_time_ns)
        if self.end_ns is not None and t < self.end_ns:
            raise InputValueError(
                f"frame time {t} ns goes back before the previous frame ({self.end_ns} ns)"
            )
        seq = self._writer.write_image(self.camera_id, data, t, capture_ns)
        self.start_ns = t if self.start_ns is None else self.start_ns
        self.end_ns = t
        self.n_frames += 1
        return seq

    def mark_incomplete(self, reason: str) -> None:
        """Mark the capture incomplete, with the reason."""
        self._incomplete_reason = reason or "incomplete"

    @property
    def incomplete_reason(self) -> str:
        """Why the capture is incomplete ("": complete so far); after the exit, its window's."""
        return self._incomplete_reason

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        """End the capture: write its window, incomplete if an error ended it."""
        self._writer._begin_capture(None)
        self._incomplete_reason = self._incomplete_reason or _stop_reason(exc_type, exc)
        if not self._writer.is_open:
            return
        now = self._writer.last_ns
        window = CaptureWindow(
            trial=self.trial,
            pose=self.pose,
            camera_id=self.camera_id,
            start_ns=self.start_ns if self.start_ns is not None else now,
            end_ns=self.end_ns if self.end_ns is not None else now,
            n_frames=self.n_frames,
            status="incomplete" if self._incomplete_reason else "complete",
            reason=self._incomplete_reason,
            dropped_frames=self.dropped_frames,
            capture=self.number,
        )
        self._writer.write_entry(window, now)


class Stream:
    """A stream trial of a two-camera session being written (format 1.6).

    Both cameras' frames (:meth:`add_frame`, :meth:`add_encoded`), each with its capture
    time on its camera's clock (strictly increasing per camera, as its log time is), and
    the touches (:meth:`touch`). Its frames go in windows of ``window_s`` seconds of log
    time: when a frame comes past the open window's span, the window is closed for both
    cameras (each camera's :class:`StreamWindow` spans its own frames in it), flushed and
    synced, and the next announced ``open``. On exit the last window is closed,
    ``incomplete`` with the reason after an error (:meth:`mark_incomplete`).
    """

    def __init__(
        self, writer: _Writer, trial: int, *, window_s: float, start_ns: int | None
    ) -> None:
        if not (math.isfinite(window_s) and window_s > 0):
            raise InputValueError(f"a stream's window must be a duration > 0 s, got {window_s}")
        self._writer = writer
        self.trial = trial
        self.cameras: Sequence[str] = writer.info.camera_ids
        self.window_ns = max(round(window_s * 1e9), 1)
        self._start_ns = start_ns
        #: The open window's number (from 1) and when it opened (log time, ns).
        self.window = 0
        self.opened_ns = 0
        self._span: dict[str, tuple[int, int, int]] = {}  # camera: first, last log, frames
        self._dropped: dict[str, int] = {}
        self._last: dict[str, tuple[int, int]] = {}  # camera: last log time, capture time
        #: Frames written per camera, and the touches marked.
        self.n_frames: dict[str, int] = dict.fromkeys(self.cameras, 0)
        self.touches: list[Touch] = []
        self._reason = ""

    def __enter__(self) -> Self:
        """Begin the stream: announce its first window (one stream or capture at a time)."""
        self._writer._begin_capture(self)
        t = self._writer.time(self._start_ns)
        self._writer.write_entries(self._open_window(t), t)
        return self

    def _open_window(self, t_ns: int) -> list[StreamWindow]:
        """The next window's announcements (its span and dropped counts begin)."""
        self.window += 1
        self.opened_ns = t_ns
        self._span, self._dropped = {}, dict.fromkeys(self.cameras, 0)
        return [self._entry(c, t_ns, t_ns, 0, "open") for c in self.cameras]

    def _entry(
        self, camera: str, start: int, end: int, n: int, status: WindowStatus, reason: str = ""
    ) -> StreamWindow:
        return StreamWindow(
            trial=self.trial, camera_id=camera, window=self.window, start_ns=start, end_ns=end,
            n_frames=n, status=status, reason=reason, dropped_frames=self._dropped[camera],
        )  # fmt: skip

    def _closing(self, status: WindowStatus, reason: str) -> list[StreamWindow]:
        """The open window's closing entries: each camera's span of its frames in it."""
        entries = []
        for c in self.cameras:
            first, last, n = self._span.get(c, (self.opened_ns, self.opened_ns, 0))
            entries.append(self._entry(c, first, last, n, status, reason))
        return entries

    def add_frame(
        self,
        camera_id: str,
        image_bgr: NDArray[np.uint8],
        capture_ns: int,
        log_time_ns: int | None = None,
    ) -> int:
        """Encode and write one frame of ``camera_id``, taken at ``capture_ns``.

        ``capture_ns`` on the camera's capture clock (the driver's stamp, or the monotonic
        clock at grab: the session entry's ``clocks`` says which); ``log_time_ns`` when it
        is written (default: the writer's clock). Its sequence number on the image topic.
        """
        data = self._writer.encode_image(image_bgr)
        return self.add_encoded(camera_id, data, capture_ns, log_time_ns)

    def add_encoded(
        self, camera_id: str, data: bytes, capture_ns: int, log_time_ns: int | None = None
    ) -> int:
        """Write one already-encoded frame (:meth:`add_frame`'s times)."""
        self._writer._check_camera(camera_id)
        capture = index(capture_ns, "capture time (ns)")
        t = self._writer.time(log_time_ns)
        if camera_id in self._last:
            last_t, last_capture = self._last[camera_id]
            if t <= last_t:
                raise InputValueError(
                    f"camera {camera_id}'s frame written at {t} ns is not after its previous "
                    f"frame ({last_t} ns)"
                )
            if capture <= last_capture:
                raise InputValueError(
                    f"camera {camera_id}'s capture time {capture} ns is not after its previous "
                    f"frame's ({last_capture} ns): a frame given twice, or a clock gone back"
                )
        if self._span and t >= self.opened_ns + self.window_ns:  # closed, synced, the next
            closing = self._closing("complete", "")
            self._writer.write_entries([*closing, *self._open_window(t)], t, sync=True)
        seq = self._writer.write_image(camera_id, data, t, capture)
        first, _, n = self._span.get(camera_id, (t, t, 0))
        self._span[camera_id] = (first, t, n + 1)
        self._last[camera_id] = (t, capture)
        self.n_frames[camera_id] += 1
        return seq

    def dropped(self, camera_id: str, n: int = 1) -> None:
        """Count ``n`` frames ``camera_id`` delivered that the recorder was too late to take."""
        self._writer._check_camera(camera_id)
        self._dropped[camera_id] += index(n, "dropped frames")

    def touch(
        self,
        point: tuple[float, float, float],
        time_ns: int,
        how: TouchMark,
        log_time_ns: int | None = None,
    ) -> Touch:
        """Mark a touch: the target at the grid ``point`` at ``time_ns`` (camera 1's clock).

        Numbered in the trial from 1; written and flushed at once.
        """
        touch = Touch(
            trial=self.trial, touch=len(self.touches) + 1, time_ns=time_ns, point=point, how=how
        )
        self._writer.write_entry(touch, log_time_ns)
        self.touches.append(touch)
        return touch

    def mark_incomplete(self, reason: str) -> None:
        """Close the stream's last window incomplete, with the reason (a camera stopped)."""
        self._reason = reason or "incomplete"

    def __exit__(
        self,
        exc_type: type[BaseException] | None,
        exc: BaseException | None,
        tb: TracebackType | None,
    ) -> None:
        """End the stream: close its last window, incomplete if an error ended it."""
        self._writer._begin_capture(None)
        self._reason = self._reason or _stop_reason(exc_type, exc)
        if self._writer.is_open:
            status: WindowStatus = "incomplete" if self._reason else "complete"
            self._writer.write_entries(
                self._closing(status, self._reason), self._writer.last_ns, sync=True
            )
