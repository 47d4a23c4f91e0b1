"""The live pointing panel in a real headless Chromium at 1366x768 (Debian's chromium and
chromium-driver, Selenium): it says when no pair runs, draws the point, its 95% region and
the track pushed to it with the conditioning in words, shows a near-singular pair as such
(its reason, no point drawn), and a page of another site cannot read the push stream.

A screenshot of each state is saved for a person to look at: into
``$TWOPOSE_SCREENSHOTS/pointing/`` when that variable names a folder, else into
``results/screenshots/pointing/``.
"""

from __future__ import annotations

import dataclasses
import json
import math
import os
import socket
import threading
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
import uvicorn

from recorder.console.pointing_server import pointing_app
from recorder.console.server import ConsoleOptions, console_app
from recorder.console.state import ConsoleSession
from recorder.live.pointing import Ellipse95, PointingEstimate
from recorder.live.pointing_feed import PointingFeed
from tests.browser import headless_chromium, require_chromium
from tests.helpers import SMALL_SCENE
from tests.recorder.test_console_cross_origin import chromium_resolving_evil, evil_server
from tests.recorder.test_console_guard import GIVEN, LINE_SETUP

require_chromium()

# Slow (a real browser): make test-all and CI run it.
pytestmark = pytest.mark.slow

ABOUT = {
    "about": "Method 2 (ground), seen on the floor from above (in)", "units": "in",
    "axes": ["across", "ahead"], "span": 3.0, "method": "ground", "fps": 30.0,
}  # fmt: skip
# Count the canvas' pixels of the point's red (#d62728) and of the track's blue.
COLOURS = """
const c = document.getElementById("pointing-canvas");
const d = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
let red = 0, blue = 0;
for (let i = 0; i < d.length; i += 4) {
  if (d[i + 3] > 200 && Math.abs(d[i] - 214) < 12 && d[i + 1] < 60 && d[i + 2] < 60) red++;
  if (d[i + 3] > 60 && d[i] < 90 && d[i + 2] > 150) blue++;
}
return [red, blue];
"""


def screenshots() -> Path:
    base = os.environ.get("TWOPOSE_SCREENSHOTS") or "results/screenshots"
    folder = Path(base) / "pointing"
    folder.mkdir(parents=True, exist_ok=True)
    return folder


@pytest.fixture
def served() -> Iterator[tuple[PointingFeed, str]]:
    """The pointing page's app on a free loopback port, its feed."""
    feed, closing = PointingFeed(), threading.Event()
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen(16)
    config = uvicorn.Config(pointing_app(feed, closing), log_level="warning", lifespan="off",
                            ws="none")  # fmt: skip
    server = uvicorn.Server(config)
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    try:
        yield feed, f"http://127.0.0.1:{sock.getsockname()[1]}"
    finally:
        closing.set()
        feed.close()
        server.should_exit = True
        thread.join(timeout=5)


def circling(n: int) -> list[PointingEstimate]:
    """A second of pairs circling on the floor (the last one's track holds them all)."""
    out, track = [], []
    for k in range(n):
        a = 2 * math.pi * k / n
        point = (1.0 * math.cos(a), 10.0 + 1.0 * math.sin(a))
        track.append((k, *point))
        out.append(
            PointingEstimate(
                seq=k,
                t_capture_ns=time.monotonic_ns(),
                t_ns=0.0,
                skew_ns=0,
                status="ok",
                words="ok",
                point=point,
                point_3d=(point[0], 9.6, point[1]),
                region=Ellipse95(major=0.3, minor=0.12, angle_deg=25.0),
                track=tuple(((k - j) / 30, u, v) for j, u, v in track),
                done_ns=0,
                cpu_ns=4_000_000,
            )
        )
    return out


def text(browser: Any, testid: str) -> str:
    value: str = browser.find_element("css selector", f"[data-testid={testid}]").text
    return value


def wait_text(browser: Any, testid: str, part: str) -> str:
    for _ in range(100):
        if part in (found := text(browser, testid)):
            return found
        time.sleep(0.05)
    raise AssertionError(f"{testid} never said {part!r}; it says {text(browser, testid)!r}")


def test_the_panel_draws_the_point_its_region_track_and_conditioning(served) -> None:
    feed, url = served
    folder = screenshots()
    with headless_chromium(1366, 768) as browser:
        browser.get(url + "/")
        said = wait_text(browser, "pointing-conditioning", "no pair running")
        assert said == "no pair running (it needs two cameras)"
        browser.save_screenshot(str(folder / "1-no-pair.png"))
        feed.start(ABOUT)
        pairs = circling(30)
        feed.publish(pairs)
        wait_text(browser, "pointing-conditioning", "conditioning: ok")
        numbers = wait_text(browser, "pointing-numbers", "capture to page")
        u, v = pairs[-1].point or (0, 0)
        assert f"across {u:.2f}, ahead {v:.2f} in" in numbers
        assert "95%: \u00b10.30 \u00d7 0.12 in" in numbers
        red, blue = browser.execute_script(COLOURS)
        assert red > 40  # the point and its region
        assert blue > 40  # the track
        browser.save_screenshot(str(folder / "2-pointing.png"))
        log = browser.execute_script("return window.twoposePointing.log;")
        assert [row[0] for row in log] == list(range(30))
        singular = PointingEstimate(
            seq=30, t_capture_ns=time.monotonic_ns(), t_ns=0.0, skew_ns=0,
            status="near_singular", words="near-singular: line-floor angle 3.10 deg < 10 "
            "(the finger's line is nearly parallel to the plane it points at)", point=None,
            point_3d=None, region=None, track=circling(30)[-1].track, done_ns=0, cpu_ns=0,
        )  # fmt: skip
        feed.publish([singular])
        said = wait_text(browser, "pointing-conditioning", "near-singular")
        assert said == "no point: " + singular.words
        conditioning = browser.find_element("css selector", "[data-testid=pointing-conditioning]")
        assert "singular" in conditioning.get_attribute("class").split()
        red, blue = browser.execute_script(COLOURS)
        assert red == 0  # no point, no region
        assert blue > 40  # the track alone
        browser.save_screenshot(str(folder / "3-near-singular.png"))
        feed.stop("the cameras' streams ended")
        wait_text(browser, "pointing-conditioning", "the cameras' streams ended")
        box = browser.find_element("css selector", "#pointing-box")
        assert box.is_displayed()  # the last pair's drawing stays, greyed
        assert "stopped" in box.get_attribute("class").split()
        browser.save_screenshot(str(folder / "6-stopped.png"))


def test_a_warned_pair_is_never_ok_on_the_page(served) -> None:
    """Two copies of one recording (the source's warning on camera 2): the page says the
    warning where "conditioning: ok" would be, in amber, for every pair it draws (it was said
    only in the terminal, the page reading "conditioning: ok": a new user's r5 F3)."""
    from recorder.console.pointing_server import about
    from recorder.sources.base import SourceInfo
    from recorder.sources.pair import CameraStream
    from twopose.methods.specs import Method
    from twopose.pair.motion import thesis_pair

    feed, url = served
    info = SourceInfo(description="video", width=640, height=480, fps=30.0)
    warning = "camera 2's files (b.avi) are camera 1's (a.avi), byte for byte"
    cameras = (
        CameraStream(spec="video:a.avi", info=info, fourcc="MJPG", clock="file",
                     clock_note="the file's own timestamps"),
        CameraStream(spec="video:b.avi", info=info, fourcc="MJPG", clock="file",
                     clock_note="the file's own timestamps", warning=warning),
    )  # fmt: skip
    with headless_chromium(1366, 768) as browser:
        browser.get(url + "/")
        wait_text(browser, "pointing-conditioning", "no pair running")
        feed.start(about(Method.GROUND, thesis_pair(), cameras))
        feed.publish(circling(10))
        said = wait_text(browser, "pointing-conditioning", "not to be trusted")
        assert said == f"not to be trusted: {warning}"
        words = browser.find_element("css selector", "[data-testid=pointing-conditioning]")
        assert "singular" in words.get_attribute("class").split()  # amber, never "ok"
        browser.save_screenshot(str(screenshots() / "7-warned-pair.png"))
        # The pairs' own warning (camera 2's frames alike camera 1's, bytes aside).
        alike = "camera 2 saw the target at camera 1's pixel in 30 of 30 pairs"
        feed.start(about(Method.GROUND, thesis_pair()))
        feed.publish([dataclasses.replace(e, warning=alike) for e in circling(10)])
        said = wait_text(browser, "pointing-conditioning", "not to be trusted")
        assert said == f"not to be trusted: {alike}"
        feed.publish(circling(10))  # frames apart again: ok again
        assert wait_text(browser, "pointing-conditioning", "conditioning: ok")


def test_a_page_of_another_site_cannot_read_the_push_stream(served) -> None:
    feed, url = served
    port = int(url.rsplit(":", 1)[1])
    attack = """
    const [target, done] = [arguments[0], arguments[arguments.length - 1]];
    const seen = [];
    const source = new EventSource(target + "/api/pointing", {withCredentials: true});
    source.onmessage = (e) => seen.push("message " + e.data.slice(0, 40));
    source.onerror = () => { seen.push("error"); source.close(); };
    fetch(target + "/api/pointing", {credentials: "include"})
      .then((r) => seen.push("fetch " + r.status)).catch(() => seen.push("fetch blocked"));
    setTimeout(() => done(seen), 800);
    """
    with evil_server() as evil_port, chromium_resolving_evil() as browser:
        browser.get(url + "/")  # the operator's page: its cookie is in this browser
        for _ in range(100):
            if feed.readers:
                break
            time.sleep(0.05)
        assert feed.readers == 1
        feed.start(ABOUT)
        feed.publish(circling(3))
        browser.switch_to.new_window("tab")
        for page in (f"http://evil.example:{evil_port}/", f"http://127.0.0.1:{evil_port}/"):
            browser.get(page)
            seen = browser.execute_async_script(attack, url)
            assert not any(s.startswith("message") for s in seen), seen
            assert "error" in seen, seen
            assert feed.readers == 1  # no stream opened for the other site
        rebound = f"http://rebind.evil.example:{port}"
        browser.get(rebound + "/")
        seen = browser.execute_async_script(attack, rebound)
        assert not any(s.startswith("message") for s in seen), seen
        assert "fetch 403" in seen, seen
        assert feed.readers == 1


def test_the_recording_console_carries_the_panel(tmp_path: Path) -> None:
    """The console of a recording (``new --ui``): no pair running said in the header, the
    panel's room left to the top view; with a pair (a two-camera recording gives its feed),
    the panel in the top view's place, the rest of the page as it was, at 1366x768 without
    scrolling."""
    scene = tmp_path / "scene.toml"
    scene.write_text(SMALL_SCENE)
    options = ConsoleOptions(source=f"synthetic:{scene}", given=GIVEN, frames=2, size=(320, 240))
    session = ConsoleSession(tmp_path / "s.mcap", dict(GIVEN, size=(320, 240)))
    feed = PointingFeed()
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen(16)
    app = console_app(session, options, pointing=feed)
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning", lifespan="on", ws="none"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    folder = screenshots()
    setup = json.dumps(LINE_SETUP)
    try:
        with headless_chromium(1366, 768) as browser:
            browser.get(f"http://127.0.0.1:{sock.getsockname()[1]}/")
            browser.execute_async_script(
                "const done = arguments[arguments.length - 1];"
                "fetch('/api/setup', {method: 'POST', headers: {'Content-Type': "
                f"'application/json'}}, body: {json.dumps(setup)}}}).then((r) => done(r.status));"
            )
            wait_text(browser, "status", "pose")
            said = wait_text(browser, "pointing-badge", "no pair running")
            assert said == "pointing: no pair running (it needs two cameras)"
            panel = browser.find_element("css selector", "[data-testid=pointing]")
            assert not panel.is_displayed()  # its room is the top view's and the map's
            assert browser.find_element("css selector", "[data-testid=topview]").is_displayed()
            browser.save_screenshot(str(folder / "4-console-one-camera.png"))
            feed.start(ABOUT)
            feed.publish(circling(30))
            wait_text(browser, "pointing-conditioning", "conditioning: ok")
            assert not browser.find_element("css selector", "[data-testid=topview]").is_displayed()
            badge = browser.find_element("css selector", "[data-testid=pointing-badge]")
            assert not badge.is_displayed()
            canvas = browser.find_element("css selector", "[data-testid=pointing-canvas]")
            assert canvas.size["height"] >= 140
            assert browser.execute_script("return window.scrollY + window.scrollX;") == 0
            for testid in ("status", "accept", "quit", "pointing-numbers"):
                box = browser.find_element("css selector", f"[data-testid={testid}]").rect
                assert box["y"] + box["height"] <= 768, testid
            browser.save_screenshot(str(folder / "5-console-pointing.png"))
    finally:
        feed.close()
        server.should_exit = True
        thread.join(timeout=15)
