"""Issue 44 (8): a hostile page's handshakes are refused quietly. uvicorn printed two
warnings for each WebSocket handshake on the console (one advising ``pip install
uvicorn[standard]``, for a console that has no WebSocket by design), and the Foxglove SDK's
server printed rustls' "secure handshake failed" for each on its private TLS port: the
operator's terminal filled with noise and advice to install things. Now each socket says
it once, in one line, and no more."""

from __future__ import annotations

import logging
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path

import pytest

from recorder.console.transport import GuardedH11Protocol

_HANDSHAKE = (
    "GET / HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
    "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n"
    "Origin: http://evil.test\r\n\r\n"
)


def _handshake(port: int) -> str:
    """A foreign page's WebSocket handshake: the status line, or "" when dropped."""
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
            sock.sendall(_HANDSHAKE.format(port=port).encode())
            return sock.recv(4096).decode(errors="replace").split("\r\n", 1)[0]
    except OSError:
        return ""


@pytest.fixture
def console(tmp_path: Path) -> Iterator[int]:
    """The console's app served as ``new --ui`` serves it (its socket's protocol, no
    WebSocket library): its port."""
    import uvicorn

    from recorder.console.server import ConsoleOptions, console_app
    from recorder.console.state import ConsoleSession

    session = ConsoleSession(tmp_path / "s.mcap")
    app = console_app(session, ConsoleOptions(source="synthetic", given={}))
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen(16)
    config = uvicorn.Config(
        app, log_level="warning", lifespan="on", http=GuardedH11Protocol, ws="none"
    )
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    while not server.started:
        time.sleep(0.01)
    try:
        yield sock.getsockname()[1]
    finally:
        server.should_exit = True
        thread.join(timeout=10)
        sock.close()


def test_the_console_refuses_handshakes_in_one_line_without_install_advice(
    console: int, caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(GuardedH11Protocol, "upgrade_said", False, raising=False)
    caplog.set_level(logging.INFO)
    for _ in range(3):
        assert " 403 " in _handshake(console) + " "  # the guard's answer, as before
    said = [
        r.getMessage()
        for r in caplog.records
        if r.name.startswith("uvicorn") and r.levelno >= logging.WARNING  # what is printed
    ]
    assert len(said) == 1, said
    assert "refused a WebSocket handshake" in said[0]
    assert not any("pip install" in s or "WebSocket library" in s for s in said), said


def test_the_live_views_private_port_drops_foreign_handshakes_in_one_line(
    caplog: pytest.LogCaptureFixture, monkeypatch: pytest.MonkeyPatch
) -> None:
    from recorder.live import tls as live_tls
    from recorder.live.view import LiveView

    one_line = getattr(live_tls, "_OneLine", None)
    if one_line is not None:  # said once a process: this test's handshakes come first
        monkeypatch.setattr(one_line, "said", False)
    caplog.set_level(logging.INFO)
    view = LiveView([], port=0)
    try:
        upstream = int(view._server.port)
        for _ in range(3):
            assert " 101 " not in _handshake(upstream) + " "
        deadline = time.monotonic() + 5
        while time.monotonic() < deadline and not caplog.records:
            time.sleep(0.05)
        time.sleep(0.3)  # the SDK logs from its own threads
    finally:
        view.close()
    said = [
        r.getMessage()
        for r in caplog.records
        if r.name.startswith("foxglove") and r.levelno >= logging.WARNING  # what is printed
    ]
    assert len(said) == 1, said
    assert "dropped a connection that did not speak its TLS" in said[0]
    assert not any("Dropping client" in s or "handshake failed" in s for s in said), said
