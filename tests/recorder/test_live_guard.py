"""recorder.live.guard directly, over real WebSockets: a loopback client is relayed both ways
to the server behind the guard; a web page's Origin or a foreign Host name gets 403 before
anything reaches it; a busy port is an error at start."""

from __future__ import annotations

import socket
import threading
from collections.abc import Iterator
from typing import Any

import pytest
from websockets.exceptions import InvalidStatus
from websockets.sync.client import connect
from websockets.sync.server import ServerConnection, serve
from websockets.typing import Origin

from recorder.live.guard import SUBPROTOCOLS, LoopbackGuard


@pytest.fixture
def upstream() -> Iterator[tuple[int, list[str]]]:
    """An echo server standing in for the Foxglove server; it lists the handshakes it saw."""
    seen: list[str] = []

    def echo(ws: ServerConnection) -> None:
        seen.append(ws.request.path if ws.request else "")
        for message in ws:
            ws.send("echo " + (message if isinstance(message, str) else message.decode()))

    with serve(echo, "127.0.0.1", 0, subprotocols=SUBPROTOCOLS) as server:  # type: ignore[arg-type]
        thread = threading.Thread(target=server.serve_forever, daemon=True)
        thread.start()
        yield server.socket.getsockname()[1], seen
        server.shutdown()


@pytest.fixture
def guard(upstream: tuple[int, list[str]]) -> Iterator[LoopbackGuard]:
    g = LoopbackGuard("127.0.0.1", 0, upstream[0], origins=["http://127.0.0.1:8799"])
    yield g
    g.close()


def test_a_loopback_client_is_relayed_both_ways(guard: LoopbackGuard) -> None:
    with connect(f"ws://127.0.0.1:{guard.port}", subprotocols=SUBPROTOCOLS) as ws:  # type: ignore[arg-type]
        assert ws.subprotocol == "foxglove.sdk.v1"
        ws.send("hello")
        assert ws.recv(timeout=5) == "echo hello"
    with connect(
        f"ws://127.0.0.1:{guard.port}",
        origin=Origin("http://127.0.0.1:8799"),  # the origin it was given: the console's
        subprotocols=SUBPROTOCOLS,  # type: ignore[arg-type]
    ) as ws:
        ws.send("from the console")
        assert ws.recv(timeout=5) == "echo from the console"


def _refused(port: int, uri_host: str = "127.0.0.1", **headers: str) -> str:
    """Handshake with the guard (under ``uri_host``, connected to loopback); its 403 body."""
    sock = socket.create_connection(("127.0.0.1", port))
    with (
        pytest.raises(InvalidStatus) as refused,
        connect(
            f"ws://{uri_host}:{port}",
            sock=sock,
            subprotocols=SUBPROTOCOLS,  # type: ignore[arg-type]
            additional_headers=list(headers.items()),
        ),
    ):
        pass
    sock.close()
    assert refused.value.response.status_code == 403
    return bytes(refused.value.response.body or b"").decode()


@pytest.mark.parametrize(
    ("uri_host", "headers", "said"),
    [
        (
            "127.0.0.1",
            {"Origin": "https://evil.example"},
            "refuses web pages of 'https://evil.example'",
        ),
        ("127.0.0.1", {"Origin": "null"}, "refuses web pages of 'null'"),
        # a page served from another local port: a notebook, a dev server
        ("127.0.0.1", {"Origin": "http://localhost:8000"}, "refuses web pages of"),
        ("127.0.0.1", {"Origin": "http://127.0.0.1:8798"}, "refuses web pages of"),
        ("rebound.example", {}, "loopback hosts only, not 'rebound.example:"),  # DNS rebinding
        ("127.0.0.1", {"Host": "rebound.example"}, "loopback hosts only"),  # Host given twice
    ],
)
def test_web_pages_and_foreign_hosts_get_403_and_reach_nothing(
    guard: LoopbackGuard,
    upstream: tuple[int, list[str]],
    uri_host: str,
    headers: dict[str, str],
    said: str,
) -> None:
    assert said in _refused(guard.port, uri_host, **headers)
    assert upstream[1] == []  # the server behind never saw it


def test_an_origin_given_twice_is_refused(guard: LoopbackGuard) -> None:
    sock = socket.create_connection(("127.0.0.1", guard.port))
    with (
        pytest.raises(InvalidStatus) as refused,
        connect(
            f"ws://127.0.0.1:{guard.port}",
            sock=sock,
            subprotocols=SUBPROTOCOLS,  # type: ignore[arg-type]
            additional_headers=[("Origin", "http://localhost"), ("Origin", "https://evil.example")],
        ),
    ):
        pass
    sock.close()
    assert refused.value.response.status_code == 403


def test_a_busy_port_is_an_error_at_start(upstream: tuple[int, list[str]]) -> None:
    with socket.socket() as taken:
        taken.bind(("127.0.0.1", 0))
        taken.listen()
        with pytest.raises(OSError, match=r"\S"):
            LoopbackGuard("127.0.0.1", taken.getsockname()[1], upstream[0])


def test_the_pinned_upstream_is_reached_over_tls_only() -> None:
    """The SDK's server speaks TLS with this run's key: the guard, pinning it, gets through;
    a plain handshake (a page's ws://) and a client trusting the usual roots do not."""
    import ssl

    import foxglove
    from websockets.exceptions import InvalidMessage

    from recorder.live.tls import UpstreamSecret

    secret = UpstreamSecret.generate()
    server = foxglove.start_server(
        host="127.0.0.1",
        port=0,
        context=foxglove.Context(),
        tls_cert=secret.cert_pem,
        tls_key=secret.key_pem,
    )
    try:
        up = int(server.port)
        protocols: Any = SUBPROTOCOLS
        with (
            pytest.raises((InvalidMessage, ConnectionError, TimeoutError)),
            connect(f"ws://127.0.0.1:{up}", subprotocols=protocols, open_timeout=5),
        ):
            pass
        with (
            pytest.raises(ssl.SSLCertVerificationError),
            connect(f"wss://127.0.0.1:{up}", subprotocols=protocols, open_timeout=5),
        ):
            pass
        g = LoopbackGuard("127.0.0.1", 0, up, secret=secret)
        try:
            with connect(f"ws://127.0.0.1:{g.port}", subprotocols=SUBPROTOCOLS) as ws:  # type: ignore[arg-type]
                assert '"serverInfo"' in str(ws.recv(timeout=10))
        finally:
            g.close()
    finally:
        server.stop()
