"""The live view's front door: WebSocket handshakes from anything but the operator's own
tools are refused before they reach the Foxglove server.

Binding to 127.0.0.1 keeps other machines out, but not web pages: a page open in the
operator's browser may open ``ws://127.0.0.1:PORT`` (its ``Origin`` is the page's site,
and a page served from another local port is a foreign page too), and a DNS-rebinding
page reaches it under its own host name (its ``Host`` is not loopback). The Foxglove
SDK's server has no hook for the handshake, so :class:`LoopbackGuard` (``websockets``)
faces the operator: it answers 403 unless ``Host`` names a loopback address and
``Origin`` is absent (Foxglove's desktop app, scripts) or exactly one of the origins it
was given (the recorder's own console), then relays every message both ways.

The SDK's server still listens on a loopback port of its own, which any page could scan
for. It speaks TLS only, with a key made for this run whose certificate the guard alone
pins (:mod:`recorder.live.tls`): a page's ``ws://`` handshake is not TLS and is dropped,
and its ``wss://`` one fails on a certificate no browser trusts (a page cannot override
that). So the only socket a browser can talk to is the guard's.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from collections.abc import Iterable
from http import HTTPStatus
from typing import TYPE_CHECKING, Any

from recorder.console.loopback import is_loopback_host

if TYPE_CHECKING:
    from recorder.live.tls import UpstreamSecret

__all__ = ["LoopbackGuard"]

#: What Foxglove clients ask for (the SDK's server speaks both).
SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]


class LoopbackGuard:
    """Serve ``host:port`` (0: a free port, see :attr:`port`) and relay accepted
    connections to the Foxglove server on ``upstream_port``; runs on its own thread.

    ``secret``: the upstream's TLS certificate to pin (None: plain ``ws://``, for a test's
    stand-in server). ``origins``: the page origins let in besides none at all (exact
    ``scheme://host:port`` text, such as the console's own).
    """

    def __init__(
        self,
        host: str,
        port: int,
        upstream_port: int,
        *,
        secret: UpstreamSecret | None = None,
        origins: Iterable[str] = (),
    ) -> None:
        self.host, self.port, self.upstream_port = host, port, upstream_port
        self._secret = secret
        if secret is not None:  # a foreign page's handshake there: one quiet line at most
            from recorder.live.tls import quiet_foreign_handshakes

            quiet_foreign_handshakes()
        self._origins = frozenset(o.strip().lower().rstrip("/") for o in origins)
        self._loop = asyncio.new_event_loop()
        self._server: Any = None
        self._error: BaseException | None = None
        self._ready = threading.Event()
        self._thread = threading.Thread(target=self._run, name="live-guard", daemon=True)
        self._thread.start()
        self._ready.wait(timeout=10)
        if self._error is not None:
            raise OSError(str(self._error)) from self._error

    def _run(self) -> None:
        asyncio.set_event_loop(self._loop)
        try:
            self._loop.run_until_complete(self._start())
        except Exception as err:  # a busy port: reported by __init__
            self._error = err
            self._ready.set()
            return
        self._ready.set()
        self._loop.run_forever()

    async def _start(self) -> None:
        from websockets.asyncio.server import serve

        self._server = await serve(
            self._relay,
            self.host,
            self.port,
            process_request=self._check,
            subprotocols=SUBPROTOCOLS,  # type: ignore[arg-type]
            max_size=None,
        )
        self.port = int(self._server.sockets[0].getsockname()[1])

    def _check(self, connection: Any, request: Any) -> Any:
        """403 for a handshake from a web page or under a foreign host name.

        One ``Host`` and at most one ``Origin``: a header given twice is refused rather than
        judged by one of its copies (and never reaches the header lookup that would raise).
        """
        hosts = request.headers.get_all("Host")
        origins = request.headers.get_all("Origin")
        if len(hosts) != 1 or not is_loopback_host(hosts[0]):
            shown = hosts[0] if len(hosts) == 1 else hosts
            return connection.respond(
                HTTPStatus.FORBIDDEN, f"the live view answers loopback hosts only, not {shown!r}\n"
            )
        if len(origins) > 1 or (origins and not self._origin_allowed(origins[0])):
            shown = origins[0] if len(origins) == 1 else origins
            return connection.respond(
                HTTPStatus.FORBIDDEN, f"the live view refuses web pages of {shown!r}\n"
            )
        return None

    def _origin_allowed(self, origin: str) -> bool:
        """Exactly an origin given at start: any other page, loopback ones included (a
        notebook, a dev server in another tab), is foreign."""
        return origin.strip().lower().rstrip("/") in self._origins

    async def _relay(self, client: Any) -> None:
        """Pipe messages both ways until either side closes."""
        from websockets.asyncio.client import connect
        from websockets.typing import Subprotocol

        chosen = [client.subprotocol] if client.subprotocol else SUBPROTOCOLS
        wanted = [Subprotocol(p) for p in chosen]
        scheme = "wss" if self._secret is not None else "ws"
        tls = self._secret.client_context() if self._secret is not None else None
        async with connect(
            f"{scheme}://127.0.0.1:{self.upstream_port}",
            subprotocols=wanted,
            max_size=None,
            ssl=tls,
        ) as upstream:

            async def pump(source: Any, sink: Any) -> None:
                with contextlib.suppress(Exception):  # a side closed: the relay ends
                    async for message in source:
                        await sink.send(message)

            tasks = [
                asyncio.create_task(pump(client, upstream)),
                asyncio.create_task(pump(upstream, client)),
            ]
            _, pending = await asyncio.wait(tasks, return_when=asyncio.FIRST_COMPLETED)
            for task in pending:
                task.cancel()

    def close(self) -> None:
        if self._server is not None and self._loop.is_running():

            async def stop() -> None:
                self._server.close()
                await self._server.wait_closed()
                self._loop.stop()

            asyncio.run_coroutine_threadsafe(stop(), self._loop)
        self._thread.join(timeout=5)
