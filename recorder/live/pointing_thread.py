"""The live pointing beside a recording: frames handed over, pairs estimated on a thread.

A two-camera recording (``new --pair --ui``: :mod:`recorder.console.stream_driver`) hands
each frame it writes to a :class:`PointingThread` (:meth:`PointingThread.give`, which never
waits): the thread runs :class:`recorder.live.pointing.LivePointing` on it and publishes each
pair's estimate to the console's panel (:class:`recorder.live.pointing_feed.PointingFeed`),
off the recording's path. When the thread falls behind, the oldest frame waiting is dropped
and counted (the pairing makes no pair of it; the recording has it all). While frames flow
the panel says the pair runs; after :data:`IDLE_S` without a frame (between trials, a camera
that stalls) it says that no trial streams, until frames come again. When the recording
measures the cameras' clock offset (after a trial), :meth:`PointingThread.use_offset` makes
the next frames paired and interpolated with it (a new live estimate from the next frame on).
"""

from __future__ import annotations

import dataclasses
import threading
from collections import deque
from typing import TYPE_CHECKING, Any

from recorder.live.pointing import LivePointing
from twopose.errors import TwoposeError

if TYPE_CHECKING:
    from recorder.live.pointing_feed import PointingFeed
    from recorder.sources.pair import TimedFrame
    from twopose.pair.clock import ClockOffset

__all__ = ["IDLE_S", "IDLE_WORDS", "WAITING_FRAMES", "PointingThread"]

#: Frames waiting for the thread, at most (a second of both cameras at 30 fps).
WAITING_FRAMES = 60
#: Without a frame this long, the panel says that no trial streams.
IDLE_S = 0.5
#: What the panel says then.
IDLE_WORDS = "no trial streams: the pointing shows once a trial's frames flow"


class PointingThread:
    """Frames in (from any thread), estimates published (the module docstring).

    Parameters
    ----------
    live : LivePointing
        The pair's live estimate.
    feed : PointingFeed
        The panel's feed.
    about : dict
        The feed's status while frames flow (:func:`recorder.console.pointing_server.about`).
    """

    def __init__(self, live: LivePointing, feed: PointingFeed, about: dict[str, Any]) -> None:
        self.live, self.feed, self.about = live, feed, about
        self._cond = threading.Condition()
        self._frames: deque[TimedFrame] = deque()
        self._closed = False
        self._offset: ClockOffset | None = None  # to use from the next frame on
        self.dropped = 0  # frames the thread was too late for
        # What voided the last trial's points (a copy, a pair file not these cameras'),
        # said between trials too: the page went green-idle after the trial otherwise
        # (a new user's r8 F3)
        self.warning = ""
        # two cameras are open, no trial streams yet: said so from the start, not the
        # feed's "no pair running (it needs two cameras)" (a new user's r7 K5)
        self.feed.stop(IDLE_WORDS)
        self._thread = threading.Thread(target=self._run, name="pointing", daemon=True)
        self._thread.start()

    def give(self, frame: TimedFrame) -> None:
        """One frame, as recorded (never waits)."""
        with self._cond:
            if len(self._frames) >= WAITING_FRAMES:
                self._frames.popleft()
                self.dropped += 1
            self._frames.append(frame)
            self._cond.notify()

    def use_offset(self, offset: ClockOffset) -> None:
        """The cameras' clock offset measured: used from the next frame on."""
        with self._cond:
            self._offset = offset

    def close(self, words: str = "the recording ended") -> None:
        """The recording ended: the thread stops, the panel says why (and what voided the
        points, where something did)."""
        with self._cond:
            self._closed = True
            self._cond.notify()
        self._thread.join(timeout=2.0)
        self.feed.stop(self._with_warning(words))

    def _with_warning(self, words: str) -> str:
        """``words``, then what voided the points so far ("" none)."""
        if not self.warning:
            return words
        return f"{words}; the points were not to be trusted: {self.warning}"

    def _next(self) -> TimedFrame | None:
        """The next frame; None once closed, or after :data:`IDLE_S` without one."""
        with self._cond:
            if not self._frames and not self._closed:
                self._cond.wait(IDLE_S)
            if self._offset is not None:  # a new estimate, on the offset measured
                live = self.live
                settings = dataclasses.replace(live.settings, offset=self._offset)
                self.live = LivePointing(live.method, live.pair, settings)
                self.live.voids = live.voids  # the cameras and the pair file are the same
                self._offset = None
            return self._frames.popleft() if self._frames else None

    def _run(self) -> None:
        running = False
        try:
            self.live.warm_up()
            while not self._closed:
                frame = self._next()
                if frame is None:
                    if running:
                        self.feed.stop(self._with_warning(IDLE_WORDS))
                        running = False
                    continue
                if not running:
                    self.feed.start(self.about)
                    running = True
                self.feed.publish(self.live.add_frame(frame))
                self.warning = self.live.voids.kept
        except TwoposeError as err:
            self.feed.stop(f"the pointing stopped: {err}")
        except Exception as err:  # the panel says it; the recording goes on
            self.feed.stop(f"the pointing stopped: {type(err).__name__}: {err}")
