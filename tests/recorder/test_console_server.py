"""The web console without a browser: its API's refusals, its address, Ctrl-C and
SIGTERM (the summary once, exit 130), a missing camera before the setup, and a server
killed with SIGKILL mid-capture."""

from __future__ import annotations

import contextlib
import signal
import socket
import subprocess
import threading
import time
from pathlib import Path

import httpx
import pytest
from typer.testing import CliRunner

import analysis
from recorder.cli.app import app
from tests.helpers import RECORD, start_console
from twopose.format import SessionReader
from twopose.format.entries import CaptureDecision


def test_the_api_refuses_what_the_state_does_not_allow(tmp_path: Path) -> None:
    process, url, _ = start_console(tmp_path / "s.mcap")
    try:
        client = httpx.Client(base_url=url, timeout=10)
        assert client.get("/api/state").status_code == 403  # no token: the page not loaded
        assert "twopose console" in client.get("/").text  # the page sets the token
        assert client.get("/api/state").json()["phase"] == "setup"
        refused = {
            "/api/pose": {"x": "0", "y": "0", "z": "0"},
            "/api/decide": {"decision": "accept"},
            "/api/note": {"text": "hello"},
        }
        for path, body in refused.items():
            answer = client.post(path, json=body)
            assert answer.status_code == 400, path
            assert answer.json()["error"]
        assert client.post("/api/decide", json={"decision": "maybe"}).status_code == 400
        assert not (tmp_path / "s.mcap").exists()  # nothing recorded
    finally:
        process.terminate()
        process.wait(timeout=30)


def test_only_loopback_unless_host_says_so_and_then_a_warning(tmp_path: Path) -> None:
    process, url, _ = start_console(tmp_path / "a.mcap")
    process.terminate()
    process.wait(timeout=30)
    assert url.startswith("http://127.0.0.1:")
    process, url, preamble = start_console(tmp_path / "b.mcap", "--host", "0.0.0.0")
    try:
        assert url.startswith("http://0.0.0.0:")
        port = int(url.rsplit(":", 1)[1].strip("/"))
        with socket.create_connection(("127.0.0.1", port), timeout=5):
            pass
    finally:
        process.terminate()
        process.communicate(timeout=30)
    assert "warning: --host 0.0.0.0 exposes the console" in preamble


@pytest.mark.slow
def test_the_server_killed_mid_capture_loses_nothing_accepted(tmp_path: Path) -> None:
    """SIGKILL while a capture is in progress: recover salvages the file, the trial
    accepted before is measured, the capture in progress is not."""
    out = tmp_path / "killed.mcap"
    process, url, _ = start_console(out, "--frames", "40")
    client = httpx.Client(base_url=url, timeout=10)
    client.get("/")  # the page: the session's token

    def wait_for(what: str) -> dict[str, object]:
        for _ in range(600):
            state: dict[str, object] = client.get("/api/state").json()
            if state["waiting"] == what:
                return state
            time.sleep(0.05)
        raise AssertionError(f"the console never waited for {what}")

    try:
        setup = {"method": "point", "truth1": "0.5, 1.5, 11", "operator": "Ada"}
        assert client.post("/api/setup", json=setup).status_code == 200
        for x, z in (("0", "0"), ("1.5", "-1")):
            wait_for("pose")
            assert client.post("/api/pose", json={"x": x, "y": "0", "z": z}).status_code == 200
            wait_for("decision")
            assert client.post("/api/decide", json={"decision": "accept"}).status_code == 200
        wait_for("pose")
        client.post("/api/pose", json={"x": "-1", "y": "0", "z": "0"})
        for _ in range(600):  # mid-capture: some of its 40 frames written
            capture = client.get("/api/state").json()["capture"]
            if 0 < capture["frame"] < capture["n_frames"]:
                break
            time.sleep(0.02)
        else:
            raise AssertionError("the capture was never seen in progress")
        process.send_signal(signal.SIGKILL)
        process.wait(timeout=10)
    finally:
        if process.poll() is None:
            process.kill()
    fixed = tmp_path / "fixed.mcap"
    recovered = CliRunner().invoke(app, ["recover", str(out), "-o", str(fixed)])
    assert recovered.exit_code == 0, recovered.output
    trials = analysis.run([fixed], None, scene=False).trials
    assert list(trials["status"]) == ["ok", "incomplete"]
    assert trials["err"].iloc[0] < 0.5


def _wait_for(client: httpx.Client, what: str) -> None:
    for _ in range(600):
        if client.get("/api/state").json()["waiting"] == what:
            return
        time.sleep(0.05)
    raise AssertionError(f"the console never waited for {what}")


def _watch_stream(url: str, cookies: httpx.Cookies) -> threading.Thread:
    """A page watching the live image (its MJPEG stream open) until the server stops."""

    def watch() -> None:
        with (
            contextlib.suppress(httpx.HTTPError),
            httpx.stream("GET", url + "stream.mjpg", cookies=cookies, timeout=60) as r,
        ):
            for _ in r.iter_bytes():
                pass

    thread = threading.Thread(target=watch, daemon=True)
    thread.start()
    return thread


@pytest.mark.slow
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_ctrl_c_or_sigterm_closes_the_file_prints_the_summary_once_and_exits_130(
    tmp_path: Path, sig: signal.Signals
) -> None:
    """With the page watching the live image and a capture awaiting its decision: the
    summary once, exit 130, no traceback, and the capture discarded as interrupted."""
    out = tmp_path / "stopped.mcap"
    process, url, _ = start_console(out)
    client = httpx.Client(base_url=url, timeout=10)
    client.get("/")
    setup = {"method": "point", "truth1": "0.5, 1.5, 11", "operator": "Ada"}
    assert client.post("/api/setup", json=setup).status_code == 200
    for what, path, body in (
        ("pose", "/api/pose", {"x": "0", "y": "0", "z": "0"}),
        ("decision", "/api/decide", {"decision": "accept"}),
        ("pose", "/api/pose", {"x": "1", "y": "0", "z": "0"}),
    ):
        _wait_for(client, what)
        assert client.post(path, json=body).status_code == 200
    _wait_for(client, "decision")
    watcher = _watch_stream(url, client.cookies)
    time.sleep(0.5)
    process.send_signal(sig)
    rest, _ = process.communicate(timeout=60)
    watcher.join(timeout=10)
    assert process.returncode == 130, rest
    assert rest.count(f"wrote {out}") == 1, rest  # the summary, once
    assert "2 captures (1 accepted, 1 discarded" in rest
    assert rest.strip().endswith("interrupted")
    for noise in ("Traceback", "Exception in ASGI", "Cancel", "ERROR"):
        assert noise not in rest, rest
    trials = analysis.run([out], None, scene=False).trials  # closed: readable as it is
    assert list(trials["status"]) == ["incomplete"]
    with SessionReader(out) as reader:
        decisions = [e for e in reader.iter_entries() if isinstance(e, CaptureDecision)]
    assert decisions[-1].decision == "discard"
    assert decisions[-1].reason.startswith("interrupted"), decisions[-1]


def test_ctrl_c_before_the_setup_records_nothing_and_exits_130(tmp_path: Path) -> None:
    out = tmp_path / "never.mcap"
    process, _, _ = start_console(out)
    time.sleep(0.3)
    process.send_signal(signal.SIGINT)
    rest, _ = process.communicate(timeout=60)
    assert process.returncode == 130
    assert "nothing recorded" in rest
    assert not out.exists()


def test_a_missing_camera_is_said_before_the_setup_naming_source(tmp_path: Path) -> None:
    out = tmp_path / "nocam.mcap"
    done = subprocess.run(
        [str(RECORD), "new", str(out), "--ui", "--source", "video:/no/such/video.mp4"],
        capture_output=True,
        text=True,
        timeout=60,
    )
    assert done.returncode == 3
    assert "error: --source video:/no/such/video.mp4:" in done.stderr
    assert "twopose console" not in done.stdout  # no page to fill in for nothing
    assert not out.exists()


def _listening_ports(pid: int) -> set[int]:
    import psutil

    return {
        c.laddr.port
        for c in psutil.Process(pid).net_connections(kind="tcp")
        if c.status == psutil.CONN_LISTEN
    }


def _foreign_handshake(port: int, host: str, origin: str) -> str:
    """A WebSocket handshake as a page on another site sends it: the status line, or why
    there was none."""
    lines = [
        "GET / HTTP/1.1",
        f"Host: {host}",
        "Upgrade: websocket",
        "Connection: Upgrade",
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==",
        "Sec-WebSocket-Version: 13",
        "Sec-WebSocket-Protocol: foxglove.websocket.v1",
        f"Origin: {origin}",
    ]
    try:
        with socket.create_connection(("127.0.0.1", port), timeout=10) as sock:
            sock.sendall(("\r\n".join(lines) + "\r\n\r\n").encode())
            answer = sock.recv(4096).decode(errors="replace")
    except OSError as err:
        return f"dropped ({err})"
    return answer.split("\r\n", 1)[0] or "dropped"


@pytest.mark.slow
def test_no_socket_of_the_recorder_lets_a_foreign_page_in(tmp_path: Path) -> None:
    """``new --ui --live`` while it records: every listening socket of the process (the
    console, the live view's guard, the Foxglove server behind it) gets a foreign page's
    handshake, under a rebound host name and from another local page: none answers 101."""
    out = tmp_path / "s.mcap"
    process, url, _ = start_console(out, "--live", "--live-port", "0")
    try:
        client = httpx.Client(base_url=url, timeout=10)
        client.get("/")
        setup = {"method": "point", "truth1": "0.5, 1.5, 11", "operator": "Ada"}
        assert client.post("/api/setup", json=setup).status_code == 200
        _wait_for(client, "pose")
        ports = _listening_ports(process.pid)
        assert len(ports) == 3, ports  # the console, the live guard, the SDK's server
        for port in ports:
            for host, origin in [
                ("evil.test:8799", "http://evil.test:8799"),
                (f"127.0.0.1:{port}", "http://127.0.0.1:8080"),
                (f"localhost:{port}", "http://localhost:3000"),
            ]:
                status = _foreign_handshake(port, host, origin)
                assert " 101 " not in status + " ", (port, status)
        console = int(url.rstrip("/").rsplit(":", 1)[1])
        assert " 403 " in _foreign_handshake(console, "evil.test", "http://evil.test") + " "
    finally:
        process.terminate()
        said, _ = process.communicate(timeout=30)
    # Refused quietly (issue 44): a line a socket at most, no advice to install anything.
    for noise in ("pip install", "WebSocket library", "Dropping client", "handshake failed"):
        assert noise not in said, said
    assert said.count("refused a WebSocket handshake") <= 1, said
    assert said.count("did not speak its TLS") <= 1, said


def test_ui_refuses_a_plan_instead_of_ignoring_it(tmp_path: Path) -> None:
    plan = tmp_path / "plan.toml"
    plan.write_text('method = "point"\n')
    result = CliRunner().invoke(app, ["new", str(tmp_path / "s.mcap"), "--ui", "--plan", str(plan)])
    assert result.exit_code == 3
    assert "--plan records unattended and --ui asks in the browser" in result.output
    assert not (tmp_path / "s.mcap").exists()
