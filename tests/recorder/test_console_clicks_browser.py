"""No click lost (issue 55, 1), in a real headless Chromium: the console's buttons clicked
at random (seeded) moments through 20 captures (capture, accept, redo, undo, add note; quit
at the end), at every moment of a capture's cycle (typing, capturing, the preview result being
computed, deciding, the next suggestion being computed).

Watched in the page every few milliseconds: a decision button is on exactly while the
status offers it (the status said "accept, redo, undo or quit" from the capture's end while
accept came on only with the preview result, and a click in between was lost). Every click
on a button that is on reaches the recorder, which takes it or says in words why not; the
file's decisions are the clicks taken, in order, each for the trial and pose the status
named when it was clicked.

The scene is the small synthetic camera's (320x240, one frame a pose, a coarse grid of
suggestions): about 25 s of wall time, most of it the clicks' random pauses.
"""

from __future__ import annotations

import random
import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.browser import headless_chromium, require_chromium
from tests.helpers import SMALL_SCENE, start_console
from twopose.format import SessionReader
from twopose.format.entries import CaptureDecision, CaptureWindow
from twopose.format.trials import read_notes

require_chromium()

pytestmark = pytest.mark.slow

CAPTURES = 20
BUTTONS = ("capture", "accept", "redo", "undo", "note-add")
#: On-target poses (the camera centre, inches) the clicks type before capturing.
POSES = ("0, 0, 0", "1.5, 0, -1", "-1, 0, 0.5", "1, 0, 1", "-1.5, 0, -1")

#: Installed in the page: every 10 ms, whether each decision button is on exactly when the
#: status offers it; and every POST the page sends, with the recorder's answer.
WATCH = r"""
if (!window.__seen) {
  window.__seen = {samples: 0, mismatches: [], posts: []};
  const ids = {accept: "accept", accept_anyway: "accept-anyway", redo: "redo", undo: "undo"};
  const offered = (status) => {
    const m = /trial \d+ pose \d+: (?:.*: )?(.+) or quit$/.exec(status);
    return m ? m[1].split(", ").map((w) => w.replace(" ", "_")) : [];
  };
  setInterval(() => {
    const status = document.getElementById("status").textContent;
    const offers = offered(status);
    for (const [choice, id] of Object.entries(ids)) {
      const b = document.getElementById(id);
      const on = !b.disabled && b.getClientRects().length > 0;
      if (on !== offers.includes(choice)) window.__seen.mismatches.push([status, choice, on]);
    }
    window.__seen.samples++;
  }, 10);
  const fetched = window.fetch;
  window.fetch = async (url, init) => {
    const response = await fetched(url, init);
    if (init && init.method === "POST") {
      let body = {};
      try { body = await response.clone().json(); } catch (err) { body = {}; }
      const sent = JSON.parse(init.body);
      const error = body.error || "";
      window.__seen.posts.push({url: String(url), sent, status: response.status, error});
    }
    return response;
  };
}
"""

#: One click, as a hand would give it, read and given in one step of the page: the button
#: (the capture button after typing a pose into the form if it is on), whether it was on,
#: and the status the operator read.
CLICK = r"""
const [id, pose] = arguments;
const button = document.getElementById(id);
const shown = button.getClientRects().length > 0;
const on = !button.disabled && shown;
const status = document.getElementById("status").textContent;
if (on && id === "note-add") document.getElementById("note-text").value = "note " + pose;
if (on && id === "capture") {
  const [x, y, z] = pose.split(", ");
  document.getElementById("pose-x").value = x;
  document.getElementById("pose-y").value = y;
  document.getElementById("pose-z").value = z;
  document.getElementById("pose-rotation").value = "0, 0, 0";
}
if (shown) button.click();  // a hand clicks only what is shown
return [on, status];
"""

_ON = (
    "return ['capture', 'accept', 'redo', 'undo', 'note-add']"
    ".filter((id) => !document.getElementById(id).disabled)"
)


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    with headless_chromium(1366, 768) as driver:
        yield driver


def test_every_click_at_every_moment_is_taken_or_refused_in_words_and_the_file_holds_it(
    browser: Any, tmp_path: Path
) -> None:
    scene = tmp_path / "scene.toml"
    scene.write_text(SMALL_SCENE)
    out = tmp_path / "clicks.mcap"
    process, url, _ = start_console(
        out, "--source", f"synthetic:{scene}", "--frames", "1", "--method", "point",
        "--units", "in", "--focal", "262.5", "--principal", "160,120", "--width", "320",
        "--height", "240", "--ground-truth", "0.5,1.5,11", "--operator", "Ada",
        "--grid", "1", "--reach", "3",
    )  # fmt: skip
    try:
        browser.get(url)
        _start(browser)
        browser.execute_script(WATCH)
        clicks = _click_through(browser, random.Random(55))
        deadline = time.monotonic() + 60
        status = "return document.getElementById('status').textContent"
        while "the session is finished" not in browser.execute_script(status):
            assert time.monotonic() < deadline, "the session never finished"
            time.sleep(0.1)
        seen = browser.execute_script("return window.__seen")
    finally:
        process.terminate()
        process.wait(timeout=30)
    assert seen["samples"] > 250
    assert seen["mismatches"] == [], seen["mismatches"][:5]
    _check_posts(clicks, seen["posts"])
    _check_file(out, clicks, seen["posts"])


def _start(browser: Any) -> None:
    """The setup the command line gave whole, started from the page."""
    status = "return document.getElementById('status').textContent"
    deadline = time.monotonic() + 60
    while "fill in the setup" not in browser.execute_script(status):
        assert time.monotonic() < deadline, "no setup form"
        time.sleep(0.05)
    browser.execute_script("document.getElementById('setup-submit').click()")
    while "type pose 1" not in browser.execute_script(status):
        assert time.monotonic() < deadline, browser.execute_script(status)
        time.sleep(0.05)


def _click_through(browser: Any, rng: random.Random) -> list[dict[str, Any]]:
    """Click until the recorder has taken the 20th pose, then a few more, then quit (and
    confirm): every click with whether its button was on and the status it was given at."""
    clicks: list[dict[str, Any]] = []
    taken = 0
    extra = rng.randint(0, 4)
    deadline = time.monotonic() + 180
    while taken < CAPTURES or extra > 0:
        status = "return document.getElementById('status').textContent"
        assert time.monotonic() < deadline, "stuck at: " + browser.execute_script(status)
        if taken >= CAPTURES:
            extra -= 1
        time.sleep(rng.uniform(0.0, 0.15))
        on = browser.execute_script(_ON)
        off = [b for b in BUTTONS if b not in on]
        # Mostly one that is on (the session moves), else one that is off (whatever the
        # moment, the page must still be right).
        pick_on = bool(on) and (rng.random() < 0.6 or not off)
        button = rng.choice(on if pick_on else off)
        if button in ("accept", "redo", "undo") and rng.random() < 0.5:
            button = "accept"  # trials get done
        was_on, status = browser.execute_script(CLICK, button, rng.choice(POSES))
        clicks.append({"button": button, "on": was_on, "status": status})
        taken = sum(
            1 for p in _posts(browser) if p["url"].endswith("/api/pose") and p["status"] == 200
        )
    time.sleep(rng.uniform(0.0, 0.15))
    confirmed = False
    while not confirmed:  # quit is off while an answer is on its way: clicked again
        assert time.monotonic() < deadline, "quit never confirmed"
        was_on, status = browser.execute_script(CLICK, "quit", "")
        clicks.append({"button": "quit", "on": was_on, "status": status})
        time.sleep(0.05)
        confirmed, status = browser.execute_script(CLICK, "quit-confirm", "")
        clicks.append({"button": "quit-confirm", "on": confirmed, "status": status})
    while not any(p["sent"].get("decision") == "quit" for p in _posts(browser)):
        assert time.monotonic() < deadline, "the quit never answered"
        time.sleep(0.05)
    return clicks


def _posts(browser: Any) -> list[dict[str, Any]]:
    posts: list[dict[str, Any]] = browser.execute_script("return window.__seen.posts")
    return posts


def _check_posts(clicks: list[dict[str, Any]], posts: list[dict[str, Any]]) -> None:
    """Every click on a button that was on was sent, in order; each answer is taken or a
    refusal in words."""
    sent = [p for p in posts if p["url"].endswith(("/api/decide", "/api/pose", "/api/note"))]
    clicked = [c for c in clicks if c["on"] and c["button"] not in ("quit",)]
    assert len(sent) == len(clicked), (len(sent), len(clicked))
    by_url = {"/api/pose": "capture", "/api/note": "note-add"}
    for click, post in zip(clicked, sent, strict=True):
        what = by_url.get(post["url"]) or post["sent"]["decision"]
        assert what == {"quit-confirm": "quit"}.get(click["button"], click["button"])
        assert post["status"] in (200, 400), post
        if post["status"] == 400:
            assert len(post["error"].split()) >= 3, post  # said in words
    decided = [c for c in clicks if c["on"] and c["button"] in ("accept", "redo", "undo")]
    assert len(decided) >= CAPTURES - 1
    # Clicks came at every moment of a capture's cycle (on buttons that were off then).
    for moment in ("type pose", "sent", "capturing", "or quit", "computing"):
        assert any(moment in c["status"] for c in clicks if not c["on"]), moment


def _check_file(out: Path, clicks: list[dict[str, Any]], posts: list[dict[str, Any]]) -> None:
    """The file's captures are the poses taken; its decisions are the decisions taken, in
    order, each for the trial and pose its click's status named; an undo also discards the
    capture it undid; the capture left undecided at quit is discarded as quit."""
    with SessionReader(out) as reader:
        entries = list(reader.iter_entries(topics=[CaptureWindow.TOPIC, CaptureDecision.TOPIC]))
    windows = [e for e in entries if isinstance(e, CaptureWindow)]
    decisions = [e for e in entries if isinstance(e, CaptureDecision)]
    assert len(windows) == CAPTURES
    clicked = [c for c in clicks if c["on"] and c["button"] in ("accept", "redo", "undo")]
    answers = [
        p for p in posts if p["url"].endswith("/api/decide") and p["sent"]["decision"] != "quit"
    ]
    taken = [c for c, p in zip(clicked, answers, strict=True) if p["status"] == 200]
    expected: list[tuple[str, str, int, int]] = []
    for click in taken:
        where = re.search(r"trial (\d+) pose (\d+):", click["status"])
        assert where, click
        trial, pose = int(where.group(1)), int(where.group(2))
        verdict = "accept" if click["button"] == "accept" else "discard"
        reason = "" if click["button"] == "accept" else click["button"]
        expected.append((verdict, reason, trial, pose))
        if click["button"] == "undo":
            expected.append(("discard", "undone", trial, pose - 1))
    notes = [p["sent"]["text"] for p in posts if p["url"] == "/api/note" and p["status"] == 200]
    with SessionReader(out) as reader:
        typed = [n for trial in read_notes(reader).by_trial.values() for n in trial]
    assert [n for n in typed if not n.startswith("guidance:")] == notes
    got = [(d.decision, d.reason.split(" by ")[0], d.trial, d.pose) for d in decisions]
    if len(got) == len(expected) + 1:  # the last capture, undecided at quit
        assert got[-1][:2] == ("discard", "quit"), got[-1]
        got = got[:-1]
    assert got == expected
