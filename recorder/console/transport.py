"""The console's socket: limits every connection lives under, before any request exists.

The console's guard (:mod:`recorder.console.guard`) judges requests; this module guards the
socket they arrive on, so that a page or a local program that never finishes a request
cannot lock the operator out (a "slow loris": connections that send one header line every
few seconds until the recorder runs out of file descriptors). :class:`GuardedH11Protocol`
is uvicorn's HTTP/1.1 protocol with three rules added:

- **A header deadline.** A request's headers must be complete within
  :data:`HEADER_TIMEOUT_S` of the connection opening (or of the previous response on a
  kept-alive connection), however slowly they trickle; otherwise the connection is closed.
- **A connection bound.** At most :data:`MAX_CONNECTIONS` connections are open, far below
  the 1024 file descriptors a process usually has. A connection past the bound evicts the
  oldest one still waiting for headers that has never been answered (a browser sends its
  headers at once, so the operator's requests are never the ones waiting), else the
  oldest kept-alive one waiting for its next request (the browser opens another); if
  every connection is busy with a request, the new one is closed at once. The server
  accepts at most :data:`ACCEPT_BURST` connections each time it wakes (asyncio accepts
  up to its backlog at once, uvicorn's 2048 by default), so evictions keep pace and the
  descriptors never run out.
- **Upgrades refused quietly.** The console has no WebSocket (``ws="none"``): an upgrade
  request is judged by the guard like any other (403 from a foreign page). uvicorn would
  print two warnings for each, one advising to install a WebSocket library; the first
  is said in one line instead, the rest not at all (a hostile page may send thousands).
- **Headers of sane size, said in words.** Headers up to :data:`MAX_HEADER_BYTES` are read
  (cookies that other local pages set for the console's host count here: cookies ignore
  ports), and a request beyond that gets a page that says why and what to do, with the
  console's security headers, instead of a bare "400 Bad Request".
"""

from __future__ import annotations

import asyncio
import time
from typing import Any, ClassVar

import h11
from typing_extensions import override
from uvicorn.protocols.http.h11_impl import H11Protocol

__all__ = [
    "ACCEPT_BURST",
    "HEADER_TIMEOUT_S",
    "MAX_CONNECTIONS",
    "MAX_HEADER_BYTES",
    "GuardedH11Protocol",
]

HEADER_TIMEOUT_S = 10.0
MAX_CONNECTIONS = 200
ACCEPT_BURST = 64
MAX_HEADER_BYTES = 1024 * 1024  # a browser's cookies for one host stay well under this

_TOO_LARGE_PAGE = (
    "<!doctype html><meta charset=utf-8><title>twopose console: request refused</title>"
    "<h1>The console could not read this request</h1>"
    "<p>Its headers are malformed or larger than {limit} KB. This is most often cookies: "
    "other pages served from this machine can set cookies for its address (cookies ignore "
    "ports), and the browser sends them all. Clear this site's cookies (in Chromium: the "
    "icon left of the address, then <i>Cookies and site data</i>) and reload the page. "
    "The recording is not affected.</p>"
)


class GuardedH11Protocol(H11Protocol):
    """uvicorn's HTTP/1.1 protocol under the socket's limits (the module docstring).

    Pass the class as ``uvicorn.Config(http=GuardedH11Protocol,
    h11_max_incomplete_event_size=MAX_HEADER_BYTES)``.
    """

    #: Whether an upgrade request was said already (once a process: see the module).
    upgrade_said: ClassVar[bool] = False

    def __init__(self, *args: Any, **kwargs: Any) -> None:
        super().__init__(*args, **kwargs)
        self.opened_at = time.monotonic()
        self.awaiting_headers = True
        self.answered = 0  # responses sent on this connection
        self._header_bytes = 0  # received while awaiting this request's headers
        self._header_deadline: asyncio.TimerHandle | None = None

    @override
    def connection_made(self, transport: asyncio.Transport) -> None:  # type: ignore[override]
        super().connection_made(transport)
        self._await_headers()
        _evict_over_bound(self)

    @override
    def connection_lost(self, exc: Exception | None) -> None:
        self._cancel_deadline()
        super().connection_lost(exc)

    @override
    def data_received(self, data: bytes) -> None:
        if self.awaiting_headers:
            self._header_bytes += len(data)
            if self._header_bytes > MAX_HEADER_BYTES:  # h11 would judge a whole read only
                self.send_400_response("the request's headers are too large")
                return
        super().data_received(data)
        if self.awaiting_headers and self.conn.their_state is not h11.IDLE:
            self.awaiting_headers = False  # a whole request line and headers arrived
            self._cancel_deadline()

    @override
    def on_response_complete(self) -> None:
        self.answered += 1
        super().on_response_complete()
        if not self.transport.is_closing() and self.conn.their_state is h11.IDLE:
            self._await_headers()  # the next request on a kept-alive connection

    @override
    def _unsupported_upgrade_warning(self) -> None:
        """An upgrade request (a WebSocket handshake): one line the first time, no
        install advice (the console has no WebSocket by design); the guard answers it."""
        if not GuardedH11Protocol.upgrade_said:
            GuardedH11Protocol.upgrade_said = True
            self.logger.warning(
                "the console refused a WebSocket handshake (it has none: a page or program "
                "that is not the console's); further ones are refused without a word"
            )

    @override
    def send_400_response(self, msg: str) -> None:
        """The request could not be parsed: say why, in a page (``msg`` is uvicorn's).

        Written as raw bytes, not through h11: the request may never have been parsed (too
        large for it), and the connection is closed right after.
        """
        from recorder.console.guard import SECURITY_HEADERS

        body = _TOO_LARGE_PAGE.format(limit=MAX_HEADER_BYTES // 1024).encode()
        head = [
            "HTTP/1.1 400 Bad Request",
            "Content-Type: text/html; charset=utf-8",
            f"Content-Length: {len(body)}",
            "Connection: close",
            *(f"{k}: {v}" for k, v in SECURITY_HEADERS.items()),
        ]
        if not self.transport.is_closing():
            self.transport.write(("\r\n".join(head) + "\r\n\r\n").encode("latin-1") + body)
        self.transport.close()

    def _await_headers(self) -> None:
        self.awaiting_headers = True
        self._header_bytes = 0
        self.opened_at = time.monotonic()
        self._cancel_deadline()
        self._header_deadline = self.loop.call_later(HEADER_TIMEOUT_S, self._too_slow)

    def _cancel_deadline(self) -> None:
        if self._header_deadline is not None:
            self._header_deadline.cancel()
            self._header_deadline = None

    def _too_slow(self) -> None:
        if self.awaiting_headers and not self.transport.is_closing():
            self.transport.close()


def _evict_over_bound(newest: GuardedH11Protocol) -> None:
    """Past :data:`MAX_CONNECTIONS`: close a connection waiting for headers (never
    answered ones first, the oldest first), or the newest if none is waiting."""
    if len(newest.connections) <= MAX_CONNECTIONS:
        return
    waiting = [
        c
        for c in newest.connections
        if isinstance(c, GuardedH11Protocol)
        and c.awaiting_headers
        and c is not newest
        and not c.transport.is_closing()
    ]
    victim = min(waiting, key=lambda c: (c.answered > 0, c.opened_at)) if waiting else newest
    victim.transport.close()
