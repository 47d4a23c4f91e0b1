"""The pointing panel's push stream and the page's clock (issue 58 item 5).

``GET /api/pointing`` is a Server-Sent Events stream (``text/event-stream``; the page reads
it with ``EventSource``): the pair's status first (running or not, in words), then one
event per pair as soon as its estimate is made (:class:`recorder.live.pointing_feed.
PointingFeed`), each stamped with ``sent_ns``, the server's monotonic clock when it left,
and a comment line every :data:`KEEPALIVE_S` while nothing happens. It is pushed, not
polled: a pair's point reaches the page within a frame interval of its estimate. The
stream is served by the console's own server, on its own port, behind its guard
(:mod:`recorder.console.guard`: ``/api/`` needs the session's cookie and the console's own
origin, so a foreign page's ``EventSource`` gets a 403 and nothing else).

``GET /api/clock`` answers the server's monotonic clock (``t_ns``): the page measures its
own clock's offset from it by round trips (the one with the shortest round trip, its
uncertainty half of it), so that the page can say, and the benchmark can measure, how long
a pair took from its capture to the page on one clock.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
import time
from collections.abc import AsyncIterator
from typing import TYPE_CHECKING, Any

from starlette.requests import Request
from starlette.responses import Response, StreamingResponse
from starlette.routing import Route

from recorder.console.guard import ConsoleJSONResponse
from twopose.values import jsonsafe

if TYPE_CHECKING:
    from recorder.live.pointing_feed import PointingFeed

__all__ = ["KEEPALIVE_S", "clock", "pointing_routes", "pointing_stream"]

#: A comment line this often keeps the stream open through idle stretches.
KEEPALIVE_S = 5.0
_WAIT_S = 0.5  # how often the stream looks whether the page went away


def _event(message: dict[str, object]) -> bytes:
    """One SSE event: the message as JSON, stamped with the moment it is sent."""
    stamped = {**message, "sent_ns": time.monotonic_ns()}
    text = jsonsafe.dumps(stamped, ensure_ascii=False, separators=(",", ":"), default=str)
    return f"data: {text}\n\n".encode()


async def _events(
    feed: PointingFeed, request: Request, closing: threading.Event
) -> AsyncIterator[bytes]:
    """The status, then every message as it comes, until the page goes away or the
    server stops (``closing``)."""
    seen = feed.last
    loop, ready = asyncio.get_running_loop(), asyncio.Event()

    def wake() -> None:  # the producer's thread: hand the wake to this stream's loop
        with contextlib.suppress(RuntimeError):  # the loop closed: nobody to wake
            loop.call_soon_threadsafe(ready.set)

    unwatch = feed.watch(wake)
    feed.joined()
    try:
        yield b"retry: 1000\n" + _event(feed.status)
        quiet = time.monotonic()
        while True:
            ready.clear()  # before looking: a message after this wakes the wait below
            ended = feed.closed or closing.is_set()  # before reading: nothing after it is lost
            seen, messages, missed = feed.after(seen, 0.0)
            if missed:
                yield _event({"kind": "missed", "count": missed})
            for message in messages:
                yield _event(message)
            if messages or missed:
                quiet = time.monotonic()
            elif time.monotonic() - quiet > KEEPALIVE_S:
                quiet = time.monotonic()
                yield b": still here\n\n"
            if ended or await request.is_disconnected():
                return  # every message before the close was sent
            if not (messages or missed):
                with contextlib.suppress(TimeoutError):
                    await asyncio.wait_for(ready.wait(), _WAIT_S)
    finally:
        unwatch()
        feed.left()


def pointing_stream(feed: PointingFeed, closing: threading.Event) -> Any:
    """The route of ``GET /api/pointing`` for ``feed`` (``closing``: the server stops)."""

    async def serve(request: Request) -> Response:
        return StreamingResponse(
            _events(feed, request, closing),
            media_type="text/event-stream",
            headers={"Cache-Control": "no-store", "X-Accel-Buffering": "no"},
        )

    return serve


def pointing_routes(feed: PointingFeed, closing: threading.Event) -> list[Route]:
    """``GET /api/pointing`` for ``feed`` and ``GET /api/clock``, as a page's app serves them."""
    return [Route("/api/pointing", pointing_stream(feed, closing)), Route("/api/clock", clock)]


async def clock(_request: Request) -> Response:
    """``GET /api/clock``: the server's monotonic clock, for the page's offset."""
    return ConsoleJSONResponse({"t_ns": time.monotonic_ns()}, headers={"Cache-Control": "no-store"})
