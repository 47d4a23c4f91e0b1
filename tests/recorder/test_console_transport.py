"""The console's socket under abuse, in a real recorder process limited to 1024 file
descriptors: hundreds of connections that trickle their headers do not lock the operator
out, a connection that never finishes its headers is closed, and cookies other local pages
set (cookies ignore ports) neither break the page nor hide the token."""

from __future__ import annotations

import contextlib
import resource
import socket
import subprocess
import time
from collections.abc import Iterator
from pathlib import Path

import httpx
import pytest

from recorder.console.transport import HEADER_TIMEOUT_S, MAX_HEADER_BYTES
from tests.helpers import RECORD, read_line_when_printed


def _limit_descriptors() -> None:
    resource.setrlimit(resource.RLIMIT_NOFILE, (1024, 1024))


@pytest.fixture
def console(tmp_path: Path) -> Iterator[tuple[str, subprocess.Popen[str]]]:
    """``new --ui`` at ``ulimit -n 1024``: its URL and process (stderr into ``err.txt``:
    a full pipe would stall a recorder that writes much to it)."""
    process = subprocess.Popen(
        [str(RECORD), "new", str(tmp_path / "s.mcap"), "--ui", "--source", "synthetic"],
        stdout=subprocess.PIPE,
        stderr=(tmp_path / "err.txt").open("w"),
        text=True,
        preexec_fn=_limit_descriptors,
    )
    line, _ = read_line_when_printed(process, "http://", "the console's address")
    try:
        yield line.split()[2], process
    finally:
        process.terminate()
        process.communicate(timeout=30)


def _port(url: str) -> int:
    return int(url.rstrip("/").rsplit(":", 1)[1])


def _slow_connections(port: int, n: int) -> list[socket.socket]:
    """``n`` connections that have sent a request line and one header, and no more."""
    socks = []
    for _ in range(n):
        s = socket.create_connection(("127.0.0.1", port), timeout=5)
        s.sendall(b"GET /api/state HTTP/1.1\r\nHost: 127.0.0.1\r\n")
        socks.append(s)
    return socks


def _trickle(socks: list[socket.socket]) -> None:
    for s in socks:
        with contextlib.suppress(OSError):  # closed by the recorder: what it should do
            s.sendall(b"X-Slow: 1\r\n")


@pytest.mark.slow
def test_slow_connections_do_not_lock_the_operator_out(
    console: tuple[str, subprocess.Popen[str]], tmp_path: Path
) -> None:
    url, process = console
    client = httpx.Client(base_url=url, timeout=5)
    assert client.get("/").status_code == 200  # the page, and the token
    socks = _slow_connections(_port(url), 1100)  # past the bound and the 1024 descriptors
    try:
        for _ in range(5):
            _trickle(socks)
            started = time.monotonic()
            answer = client.get("/api/state")
            assert answer.status_code == 200
            assert answer.json()["phase"] == "setup"
            assert time.monotonic() - started < 3
            time.sleep(0.5)
    finally:
        for s in socks:
            s.close()
    process.terminate()
    process.communicate(timeout=30)
    assert "Too many open files" not in (tmp_path / "err.txt").read_text()


@pytest.mark.slow  # waits out the server's 10 s header timeout: make test-all and CI
def test_headers_that_never_finish_are_cut_off(
    console: tuple[str, subprocess.Popen[str]],
) -> None:
    url, _ = console
    (s,) = _slow_connections(_port(url), 1)
    started = time.monotonic()
    closed = False
    while time.monotonic() - started < HEADER_TIMEOUT_S + 10:
        try:
            s.sendall(b"X-Slow: 1\r\n")  # a line a second: progress, but never done
            s.settimeout(1)
            if s.recv(1) == b"":
                closed = True
                break
        except TimeoutError:
            continue
        except OSError:
            closed = True
            break
    s.close()
    assert closed
    assert time.monotonic() - started >= HEADER_TIMEOUT_S - 1


def test_other_pages_cookies_neither_lock_the_page_nor_hide_the_token(
    console: tuple[str, subprocess.Popen[str]],
) -> None:
    url, _ = console
    client = httpx.Client(base_url=url, timeout=5)
    assert client.get("/").status_code == 200
    junk = "; ".join(f"junk{i}={'x' * 4000}" for i in range(40))  # 40 cookies of 4 KB
    token = "; ".join(f"{k}={v}" for k, v in client.cookies.items())
    for cookie in (f"{junk}; {token}", f"{token}; {junk}"):
        bare = httpx.Client(base_url=url, timeout=5)
        assert bare.get("/api/state", headers={"Cookie": cookie}).status_code == 200
        assert bare.get("/", headers={"Cookie": junk}).status_code == 200
    # beyond what any browser sends: a page that says why, with the console's headers
    huge = "; ".join(f"junk{i}={'x' * 4000}" for i in range(MAX_HEADER_BYTES // 4000 + 10))
    answer = httpx.get(url, headers={"Cookie": huge}, timeout=10)
    assert answer.status_code == 400
    assert "Clear this site's cookies" in answer.text
    assert answer.headers["X-Frame-Options"] == "DENY"
