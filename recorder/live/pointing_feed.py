"""What the console's pointing panel shows, pushed as it happens (issue 58 item 5).

A :class:`PointingFeed` sits between whoever estimates the pairs (the pointing command's
loop, :mod:`recorder.console.pointing_server`; a two-camera recording) and the page's push
stream (``GET /api/pointing``, :mod:`recorder.console.pointing_route`). The producer says
when a pair starts running (:meth:`PointingFeed.start`: the method, the units, the plane the
point is seen on, the cameras), publishes each pair's estimate
(:meth:`PointingFeed.publish`) and says why it stopped (:meth:`PointingFeed.stop`); every
reader waits for the messages after the last it saw (:meth:`PointingFeed.after`), or is
woken as each comes (:meth:`PointingFeed.watch`: a push stream's event loop). Each
message has a number; the newest :data:`CAPACITY` are kept, so a reader that falls behind
(a page in a background tab) skips to them and is told how many it missed, never slows the
producer. A feed nobody started says that no pair is running.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from collections.abc import Callable
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from recorder.live.pointing import PointingEstimate

__all__ = ["CAPACITY", "IDLE_WORDS", "PointingFeed", "estimate_json"]

#: Messages kept for readers (at 30 pairs a second, four seconds).
CAPACITY = 120
#: What the panel says when no pair is running.
IDLE_WORDS = "no pair running (it needs two cameras)"


def estimate_json(e: PointingEstimate) -> dict[str, Any]:
    """One pair's estimate as the page reads it (times in ns and ms, lengths in the units)."""
    region = e.region
    return {
        "kind": "estimate",
        "seq": e.seq,
        "t_capture_ns": e.t_capture_ns,
        "status": e.status,
        "words": e.words,
        "point": None if e.point is None else list(e.point),
        "region": None
        if region is None
        else {"major": region.major, "minor": region.minor, "angle_deg": region.angle_deg},
        "track": [list(p) for p in e.track],
        "done_ns": e.done_ns,
        "cpu_ms": e.cpu_ns / 1e6,
        "skew_ms": e.skew_ns / 1e6,
        "noise": list(e.noise),
        "warning": e.warning,
    }


class PointingFeed:
    """The pointing panel's messages (the module docstring)."""

    def __init__(self, capacity: int = CAPACITY) -> None:
        self._cond = threading.Condition()
        self._messages: deque[tuple[int, dict[str, Any]]] = deque(maxlen=capacity)
        self._count = 0
        self._status: dict[str, Any] = {"kind": "status", "running": False, "words": IDLE_WORDS}
        self.closed = False
        #: How many pages read the feed now (their push streams open).
        self.readers = 0
        self._watchers: list[Callable[[], None]] = []

    def joined(self) -> None:
        """A page opened the push stream."""
        with self._cond:
            self.readers += 1

    def left(self) -> None:
        """A page's push stream closed."""
        with self._cond:
            self.readers -= 1

    def watch(self, wake: Callable[[], None]) -> Callable[[], None]:
        """Call ``wake`` (from the producer's thread: it must not wait) after each message
        and at close; returns what stops it."""
        with self._cond:
            self._watchers.append(wake)

        def unwatch() -> None:
            with self._cond:
                self._watchers.remove(wake)

        return unwatch

    def _wake(self) -> None:
        with self._cond:
            watchers = list(self._watchers)
        for wake in watchers:
            wake()

    def _put(self, message: dict[str, Any]) -> None:
        with self._cond:
            self._count += 1
            self._messages.append((self._count, message))
            self._cond.notify_all()
        self._wake()

    def start(self, about: dict[str, Any]) -> None:
        """A pair is running: ``about`` says the method, units, plane, cameras (words)."""
        with self._cond:
            self._status = {"kind": "status", "running": True, "words": "", **about}
            self._put(dict(self._status))

    def publish(self, estimates: list[PointingEstimate]) -> None:
        """The pairs' estimates, in order."""
        for e in estimates:
            self._put(estimate_json(e))

    def stop(self, words: str) -> None:
        """The pair stopped running, and why (its streams ended, a camera failed)."""
        with self._cond:
            self._status = {**self._status, "running": False, "words": words}
            self._put(dict(self._status))

    def close(self) -> None:
        """The server stops: every reader's wait ends now."""
        with self._cond:
            self.closed = True
            self._cond.notify_all()
        self._wake()

    @property
    def status(self) -> dict[str, Any]:
        """The last status message (running or not, and in words)."""
        with self._cond:
            return dict(self._status)

    @property
    def last(self) -> int:
        """The newest message's number (0: none yet)."""
        with self._cond:
            return self._count

    def after(self, seen: int, timeout_s: float) -> tuple[int, list[dict[str, Any]], int]:
        """The messages after number ``seen`` (waiting up to ``timeout_s`` for one): the
        newest number, the messages, and how many the reader missed (fell out)."""
        deadline = time.monotonic() + timeout_s
        with self._cond:
            while self._count <= seen and not self.closed:
                left = deadline - time.monotonic()
                if left <= 0:
                    return seen, [], 0
                self._cond.wait(left)
            new = [m for n, m in self._messages if n > seen]
            missed = self._count - seen - len(new)
            return self._count, new, missed
