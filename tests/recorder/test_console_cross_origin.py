"""Other web pages cannot drive the console nor watch its camera, in a real headless
Chromium (Debian's chromium and chromium-driver, Selenium).

The operator's page is open in one tab (so the browser holds the session's cookie, and
the live image is streaming); in another, a hostile page tries every API call and the
stream: served from another site (``evil.example``, mapped to 127.0.0.1 with
``--host-resolver-rules``), from another port of the same machine (same-site: the cookie
travels), and as a DNS-rebinding page (``rebind.evil.example`` at the console's own
port). Nothing is recorded, no frame reaches the hostile page, and the same script run
by the operator's own page does read the state and the stream (the harness works).
"""

from __future__ import annotations

import contextlib
import http.server
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import httpx
import pytest

from tests.browser import require_chromium
from tests.helpers import start_console

# Slow (a real browser, a cluster, or fits over many sessions): make test-all and CI run it.
pytestmark = pytest.mark.slow

require_chromium()

# What a hostile page runs against the console at ``target``: every API call as a simple
# request (no preflight: text/plain, no-cors), as JSON (preflighted), as a form and as a
# beacon; the state read with CORS; the stream as an image. Reports what it could see.
ATTACK = """
const [target, done] = [arguments[0], arguments[arguments.length - 1]];
const calls = [
  ["/api/setup", {method: "point", units: "in", focal: "525", principal: "320, 240",
                  truth1: "0.5, 1.5, 11", operator: "Mallory"}],
  ["/api/pose", {x: "0", y: "0", z: "0", rotation: "0, 0, 0"}],
  ["/api/decide", {decision: "accept"}],
  ["/api/note", {text: "written by another site"}],
  ["/api/decide", {decision: "quit"}],
];
const seen = {read: [], image: null};
async function attempt(what, promise) {
  try { const r = await promise; seen.read.push(what + ": " + r.type + " " + r.status); }
  catch (err) { seen.read.push(what + ": blocked"); }
}
(async () => {
  for (const [path, body] of calls) {
    const text = JSON.stringify(body);
    await attempt("plain " + path, fetch(target + path, {method: "POST", mode: "no-cors",
      credentials: "include", headers: {"Content-Type": "text/plain"}, body: text}));
    await attempt("json " + path, fetch(target + path, {method: "POST",
      credentials: "include", headers: {"Content-Type": "application/json"}, body: text}));
    navigator.sendBeacon(target + path, new Blob([text], {type: "text/plain"}));
    const frame = document.createElement("iframe");
    frame.name = "sink" + Math.random();
    document.body.appendChild(frame);
    const form = document.createElement("form");
    Object.assign(form, {method: "POST", action: target + path, enctype: "text/plain",
                         target: frame.name});
    const input = document.createElement("input");
    Object.assign(input, {name: text.slice(0, -1) + ', "pad": "', value: '"}'});
    form.appendChild(input);
    document.body.appendChild(form);
    form.submit();
    await new Promise((r) => setTimeout(r, 300));
  }
  await attempt("state", fetch(target + "/api/state", {credentials: "include"}));
  await attempt("stream", fetch(target + "/stream.mjpg", {credentials: "include"}));
  const image = new Image();
  const loaded = new Promise((resolve) => {
    image.onload = () => resolve("load");
    image.onerror = () => resolve("error");
    setTimeout(() => resolve("timeout"), 4000);
  });
  image.src = target + "/stream.mjpg";
  document.body.appendChild(image);
  const outcome = await loaded;
  seen.image = {outcome, width: image.naturalWidth};
  done(seen);
})();
"""

EVIL_PAGE = b"<!doctype html><title>a page of another site</title><body><p>hello</p>"


@contextlib.contextmanager
def evil_server() -> Iterator[int]:
    """A web server of another site: serves EVIL_PAGE on a free port of 127.0.0.1."""

    class Handler(http.server.BaseHTTPRequestHandler):
        def do_GET(self) -> None:
            self.send_response(200)
            self.send_header("Content-Type", "text/html")
            self.end_headers()
            self.wfile.write(EVIL_PAGE)

        def log_message(self, format: str, *args: Any) -> None:
            return

    server = http.server.ThreadingHTTPServer(("127.0.0.1", 0), Handler)
    thread = threading.Thread(target=server.serve_forever, daemon=True)
    thread.start()
    try:
        yield int(server.server_address[1])
    finally:
        server.shutdown()
        server.server_close()


@contextlib.contextmanager
def chromium_resolving_evil() -> Iterator[Any]:
    """Headless Chromium where evil.example and rebind.evil.example are 127.0.0.1."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    chromium, chromedriver = require_chromium()
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for flag in (
        "--headless=new",
        "--no-sandbox",
        "--disable-dev-shm-usage",
        "--disable-gpu",
        "--no-proxy-server",
        "--window-size=1280,900",
        "--host-resolver-rules=MAP evil.example 127.0.0.1, MAP rebind.evil.example 127.0.0.1",
    ):
        options.add_argument(flag)
    driver = webdriver.Chrome(service=Service(executable_path=chromedriver), options=options)
    driver.set_script_timeout(60)
    try:
        yield driver
    finally:
        driver.quit()


def attack(browser: Any, page: str, target: str) -> dict[str, Any]:
    browser.get(page)
    seen: dict[str, Any] = browser.execute_async_script(ATTACK, target)
    return seen


def test_other_pages_cannot_drive_nor_watch_the_console(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    process, url, _ = start_console(out)
    console = url.rstrip("/")
    port = int(console.rsplit(":", 1)[1])
    # A fresh connection per request: the attacks outlast uvicorn's 5 s keep-alive, and a
    # request sent on a connection the server is closing fails for the harness' reason.
    operator = httpx.Client(
        base_url=console, timeout=10, limits=httpx.Limits(max_keepalive_connections=0)
    )
    operator.get("/")

    def state() -> dict[str, Any]:
        assert process.poll() is None, "the console died"
        answer = operator.get("/api/state")
        assert answer.status_code == 200
        found: dict[str, Any] = answer.json()
        return found

    try:
        with evil_server() as evil_port, chromium_resolving_evil() as browser:
            browser.get(url)  # the operator's page: the cookie is in this browser now
            operators_tab = browser.current_window_handle
            browser.switch_to.new_window("tab")
            hostile = (
                f"http://evil.example:{evil_port}/",  # another site
                f"http://127.0.0.1:{evil_port}/",  # same site, another port
            )

            # 1. While the setup is open: nobody else can start the session.
            for page in hostile:
                seen = attack(browser, page, console)
                assert seen["image"]["width"] == 0, seen
                assert all(r.endswith(("blocked", "opaque 0")) for r in seen["read"]), seen
            time.sleep(0.5)
            assert state()["phase"] == "setup"
            assert not out.exists()  # nothing recorded

            # 2. The operator sets up; the session waits for a pose, the camera streams.
            setup = {"method": "point", "truth1": "0.5, 1.5, 11", "operator": "Ada"}
            assert operator.post("/api/setup", json=setup).status_code == 200
            for _ in range(600):
                if state()["waiting"] == "pose":
                    break
                time.sleep(0.05)
            before = state()
            for page in hostile:
                seen = attack(browser, page, console)
                assert seen["image"]["width"] == 0, seen  # no frame received
                assert seen["image"]["outcome"] in ("error", "timeout"), seen
                assert all(r.endswith(("blocked", "opaque 0")) for r in seen["read"]), seen
            time.sleep(0.5)
            after = state()
            for key in ("phase", "waiting", "trial", "pose", "poses", "results", "message"):
                assert after[key] == before[key], key
            assert after["frames"] == []
            assert after["last_capture"] == ""

            # 3. A DNS-rebinding page: the console's port under the attacker's name.
            rebound = f"http://rebind.evil.example:{port}"
            browser.get(rebound + "/")
            assert "only its own address" in browser.page_source
            seen = browser.execute_async_script(ATTACK, rebound)
            assert seen["image"]["width"] == 0, seen
            assert all(r.endswith(("403", "blocked")) for r in seen["read"]), seen
            time.sleep(0.5)
            assert state()["waiting"] == "pose"
            assert state()["frames"] == []

            # The harness works: the operator's own page reads the state and the stream.
            browser.switch_to.window(operators_tab)
            own: dict[str, Any] = browser.execute_async_script(
                """const done = arguments[arguments.length - 1];
                const image = new Image();
                image.onload = () => fetch("/api/state").then((r) => r.json()).then(
                  (s) => done({width: image.naturalWidth, waiting: s.waiting}));
                image.onerror = () => done({width: 0, waiting: "image refused"});
                image.src = "/stream.mjpg";"""
            )
            assert own == {"width": 640, "waiting": "pose"}
        assert operator.post("/api/decide", json={"decision": "quit"}).status_code == 200
        for _ in range(200):
            if state()["phase"] == "done":
                break
            time.sleep(0.05)
        assert state()["phase"] == "done"
        assert state()["summary"].startswith("nothing was recorded")
        assert not out.exists()
    finally:
        process.terminate()
        process.communicate(timeout=30)


@pytest.fixture(autouse=True)
def _no_proxy(monkeypatch: pytest.MonkeyPatch) -> None:
    """httpx and chromedriver talk to 127.0.0.1 directly."""
    for name in ("http_proxy", "HTTP_PROXY", "https_proxy", "HTTPS_PROXY", "all_proxy"):
        monkeypatch.delenv(name, raising=False)
