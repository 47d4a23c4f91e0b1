"""The live view's front door: WebSocket handshakes from anything but the operator's own
machine are refused before they reach the Foxglove server.

Binding to 127.0.0.1 keeps other machines out, but not web pages: a page open in the
operator's browser may open ``ws://127.0.0.1:PORT`` (its ``Origin`` is the page's site),
and a DNS-rebinding page reaches it under its own host name (its ``Host`` is not
loopback). The Foxglove SDK's server has no hook for the handshake, so it listens on a
private loopback port and :class:`LoopbackGuard` (``websockets``) faces the operator: it
answers 403 unless ``Host`` names a loopback address and ``Origin`` is absent (Foxglove's
desktop app, scripts) or loopback too (:mod:`twopose.loopback`, the one rule), then
relays every message both ways.
"""

from __future__ import annotations

import asyncio
import contextlib
import threading
from http import HTTPStatus
from typing import Any

from twopose.loopback import is_loopback_host, is_loopback_origin

__all__ = ["LoopbackGuard"]

#: What Foxglove clients ask for (the SDK's server speaks both).
SUBPROTOCOLS = ["foxglove.sdk.v1", "foxglove.websocket.v1"]


class LoopbackGuard:
    """Serve ``host:port`` (0: a free port, see :attr:`port`) and relay accepted
    connections to the Foxglove server on ``upstream_port``; runs on its own thread."""

    def __init__(self, host: str, port: int, upstream_port: int) -> None:
        self.host, self.port, self.upstream_port = host, port, upstream_port
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
        if len(origins) > 1 or (origins and not is_loopback_origin(origins[0])):
            shown = origins[0] if len(origins) == 1 else origins
            return connection.respond(
                HTTPStatus.FORBIDDEN, f"the live view refuses web pages of {shown!r}\n"
            )
        return None

    async def _relay(self, client: Any) -> None:
        """Pipe messages both ways until either side closes."""
        from websockets.asyncio.client import connect
        from websockets.typing import Subprotocol

        chosen = [client.subprotocol] if client.subprotocol else SUBPROTOCOLS
        wanted = [Subprotocol(p) for p in chosen]
        async with connect(
            f"ws://127.0.0.1:{self.upstream_port}", subprotocols=wanted, max_size=None
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
