"""The console's layout in a real headless Chromium (Debian's chromium and chromium-driver):
for each method at 1366x768, and for the method with the most setup fields (ground) at
1280x800, a synthetic-source session from setup to quit: a setup with bad values (every
refusal at once, each by its field), pose 1 typed looking away and captured with Enter
(found in no frame: accept off, the reason shown), redone by the keyboard (the form keeps
what was typed), undo refused at the first pose (next to the undo button), accept by the
keyboard, pose 2 (an empty form) with the result it would give before the decision,
accept, quit and its confirmation, the finished page with the summary.

At every step the status, the decision buttons and every refusal shown are inside the
viewport with the page not scrolled, and a screenshot of the step is saved for a person
to look at: into ``$TWOPOSE_SCREENSHOTS/<method>-<width>x<height>/NN-<step>.png`` when
that variable names a folder, else into ``results/screenshots/`` (CI keeps ``results/``).

The window is the screen's size: its viewport is what a browser leaves of the screen
(1366x768 gives 1366x625 in headless Chromium), as on the operator's laptop."""

from __future__ import annotations

import contextlib
import os
import signal
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.browser import emulate_phone, headless_chromium, require_chromium
from tests.doc_images import CONSOLE_VOLATILE, doc_image, live_frame_drawn
from tests.helpers import small_session, start_console

require_chromium()

from selenium.webdriver.common.action_chains import ActionChains  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.common.keys import Keys  # noqa: E402
from selenium.webdriver.support.ui import Select, WebDriverWait  # noqa: E402

# Slow (a real browser, a cluster, or fits over many sessions): make test-all and CI run it.
pytestmark = pytest.mark.slow

DECISION_BUTTONS = ("accept", "redo", "undo", "quit")
#: Every refusal the page can show; whichever is shown must be in view.
REFUSALS = (
    "[data-testid=refusal]",
    "[data-testid^=field-error-]",
    "[data-testid=setup-refusal]",
    "[data-testid=pose-refusal]",
    "[data-testid=note-refusal]",
)

#: Per method: the setup's bad values (field -> value), the fields they make refused, the
#: good values, and the fields that must not be shown for it.
SETUPS: dict[str, tuple[dict[str, str], tuple[str, ...], dict[str, str], tuple[str, ...]]] = {
    "point": (
        {"focal": "abc", "principal": "1", "truth1": "1, 2"},
        ("focal", "principal", "truth1"),
        {"focal": "", "principal": "", "truth1": "0.5, 1.5, 11", "operator": "Ada"},
        ("ground_height", "truth2", "keep_off_ground"),
    ),
    "line": (
        {"focal": "-5", "truth1": "0, 0, 10", "truth2": "0, 0, 10"},
        ("focal", "truth2"),
        {"focal": "", "truth1": "0, 0, 10", "truth2": "1, 0, 10", "operator": "Ada"},
        ("ground_height", "keep_off_ground"),
    ),
    "ground": (
        {"focal": "abc", "ground_height": "x", "truth1": "1, 2"},
        ("focal", "ground_height", "truth1"),
        {"focal": "", "ground_height": "9.625", "truth1": "1.9, 9.625, 8.4", "operator": "Ada"},
        ("truth2",),
    ),
}

IN_VIEW = """
const [selectors, required] = arguments;
const problems = [];
const shown = (e) => e.getClientRects().length > 0 && getComputedStyle(e).visibility !== "hidden";
for (const selector of [...required, ...selectors]) {
  const found = [...document.querySelectorAll(selector)];
  if (required.includes(selector) && !found.some(shown)) problems.push(selector + " not shown");
  for (const e of found.filter(shown)) {
    const r = e.getBoundingClientRect();
    if (r.left < 0 || r.top < 0 || r.right > innerWidth || r.bottom > innerHeight) {
      problems.push(`${selector} at (${r.left}, ${r.top})-(${r.right}, ${r.bottom})`);
    }
  }
}
if (scrollX || scrollY) problems.push(`the page is scrolled to (${scrollX}, ${scrollY})`);
return {problems, width: innerWidth, height: innerHeight};
"""


SCREENSHOTS = Path(__file__).resolve().parents[2] / "results" / "screenshots"
#: The steps the docs show (docs/recording.md, docs/index.md), by the image's name.
DOC_STEPS = {"pose-2": "console-pose.png", "preview": "console-preview.png"}


def _folder(name: str) -> Path:
    root = os.environ.get("TWOPOSE_SCREENSHOTS")
    folder = (Path(root) if root else SCREENSHOTS) / name
    folder.mkdir(parents=True, exist_ok=True)
    return folder


class Steps:
    """The page at each step: what must be in view, and its screenshot."""

    def __init__(self, browser: Any, folder: Path, docs: dict[str, str] | None = None) -> None:
        self.browser, self.folder, self.n = browser, folder, 0
        self.docs = docs or {}  # step -> the docs' image it is (tests/doc_images.py)

    def el(self, testid: str) -> Any:
        return self.browser.find_element(By.CSS_SELECTOR, f"[data-testid={testid}]")

    def text(self, testid: str) -> str:
        script = "const e = document.querySelector(arguments[0]); return e ? e.textContent : ''"
        return str(self.browser.execute_script(script, f"[data-testid={testid}]"))

    def shown(self, testid: str) -> bool:
        return bool(self.el(testid).is_displayed())

    def wait(self, condition: Any, what: str, timeout: float = 60) -> None:
        WebDriverWait(self.browser, timeout).until(lambda _: condition(), message=what)

    def type(self, testid: str, text: str) -> None:
        self.wait(lambda: self.el(testid).is_enabled(), f"{testid} enabled")
        element = self.el(testid)
        element.clear()
        element.send_keys(text)

    def step(self, name: str, *, recording: bool = True) -> None:
        """Everything that must be seen is in view; then the screenshot."""
        required = ["[data-testid=status]"]
        if recording:
            required += [f"[data-testid={b}]" for b in DECISION_BUTTONS]
        if self.shown("accept-anyway"):
            required.append("[data-testid=accept-anyway]")
        seen = self.browser.execute_script(IN_VIEW, list(REFUSALS), required)
        self.n += 1
        path = self.folder / f"{self.n:02d}-{name}.png"
        png = self.browser.get_screenshot_as_png()
        path.write_bytes(png)
        size = f"{seen['width']}x{seen['height']}"
        assert not seen["problems"], f"{name} ({size}): {seen['problems']}"
        if name in self.docs:
            # The live picture is left out of the comparison (CONSOLE_VOLATILE): drawn, at least.
            problem = live_frame_drawn(self.browser, png) if recording else ""
            assert not problem, f"{name}: {problem}"
            doc_image(self.docs[name], png, driver=self.browser, volatile=CONSOLE_VOLATILE)


@pytest.fixture
def console(tmp_path: Path) -> Iterator[tuple[str, Path]]:
    out = tmp_path / "layout.mcap"
    process, url, _ = start_console(out)
    try:
        yield url, out
    finally:
        process.terminate()
        process.wait(timeout=30)


@pytest.mark.slow
@pytest.mark.parametrize(
    ("method", "size"),
    [
        ("point", (1366, 768)),
        ("line", (1366, 768)),
        ("ground", (1366, 768)),
        ("ground", (1280, 800)),
    ],
)
def test_every_step_fits_the_screen(
    method: str, size: tuple[int, int], console: tuple[str, Path]
) -> None:
    url, _ = console
    bad, refused, good, absent = SETUPS[method]
    with headless_chromium(*size) as browser:
        # The docs' recording page shows the ground console at the laptop's size.
        docs = DOC_STEPS if (method, size) == ("ground", (1366, 768)) else {}
        page = Steps(browser, _folder(f"{method}-{size[0]}x{size[1]}"), docs)
        browser.get(url)
        page.wait(lambda: browser.find_elements(By.ID, "f-method"), "the setup form")
        Select(browser.find_element(By.ID, "f-method")).select_by_value(method)
        # Only the fields of the method; the thesis' defaults filled in.
        for name in absent:
            assert not browser.find_element(By.ID, f"cell-{name}").is_displayed(), name
        assert browser.find_element(By.ID, "f-focal").get_attribute("value") == "525"
        assert browser.find_element(By.ID, "f-principal").get_attribute("value") == "320, 240"
        if method == "ground":
            assert browser.find_element(By.ID, "f-ground_height").get_attribute("value") == "9.625"
        page.step("setup", recording=False)

        # Bad values: every refusal at once, each by its field, the field marked.
        for name, value in bad.items():
            page.type(f"field-{name}", value)
        page.el("setup-submit").click()
        page.wait(lambda: all(page.shown(f"field-error-{n}") for n in refused), "every refusal")
        for name in refused:
            assert page.text(f"field-error-{name}").strip()
            assert "invalid" in str(page.el(f"field-{name}").get_attribute("class"))
            assert "_" not in page.text(f"field-error-{name}"), "an internal key shown"
        page.step("setup-refused", recording=False)
        for name, value in good.items():
            page.type(f"field-{name}", value)
        page.el("setup-submit").click()
        page.wait(lambda: "type pose 1" in page.text("status"), "the first pose")
        page.wait(lambda: page.el("pose-x").is_enabled(), "the pose form")
        page.step("pose-1")

        # Pose 1 typed looking away from the target, captured with Enter: found in no
        # frame, so accept is off and the page says why; redone by the keyboard.
        for testid, value in (("pose-x", "0"), ("pose-y", "0"), ("pose-z", "0")):
            page.type(testid, value)
        page.type("pose-rotation", "0, 180, 0" + Keys.ENTER)
        page.wait(lambda: page.el("redo").is_enabled(), "the capture to end")
        assert not page.el("accept").is_enabled()
        assert "not found in any frame" in page.text("shortfall")
        assert "not found" in page.text("frames-table")
        assert "none" in page.text("pose-average")
        page.step("not-found")
        ActionChains(browser).send_keys("r").perform()
        page.wait(lambda: page.el("pose-x").is_enabled(), "the pose retyped")
        # The form holds what was typed for this pose, to correct.
        assert page.el("pose-rotation").get_attribute("value") == "0, 180, 0"

        # Pose 1 again, captured with Enter; its frames' numbers and their average.
        page.type("pose-rotation", "0, 0, 0" + Keys.ENTER)
        page.wait(lambda: page.el("accept").is_enabled(), "the capture to end")
        rows = browser.find_elements(By.CSS_SELECTOR, "[data-testid=frames-table] tbody tr")
        assert len(rows) == 2
        assert "2 of 2 frames" in page.text("pose-average")
        page.step("captured-1")

        # Undo at the first pose: refused next to the undo button.
        page.el("undo").click()
        page.wait(lambda: page.shown("refusal"), "the undo refused")
        assert "nothing to undo" in page.text("refusal")
        assert page.el("refusal").get_attribute("data-control") == "undo"
        undo, refusal = page.el("undo").rect, page.el("refusal").rect
        assert 0 <= refusal["y"] - (undo["y"] + undo["height"]) < 40
        page.step("undo-refused")

        # Accept by the keyboard; pose 2's form is empty, pose 1 listed as accepted.
        ActionChains(browser).send_keys("a").perform()  # to whatever has the focus
        page.wait(lambda: "type pose 2" in page.text("status"), "the second pose")
        page.wait(lambda: page.el("pose-x").is_enabled(), "the pose form")
        assert [page.el(f"pose-{k}").get_attribute("value") for k in "xyz"] == ["", "", ""]
        assert "accepted" in page.text("pose-list")
        assert not page.shown("refusal")
        # The map of the next poses follows the suggestion (issue 46): in the picture too.
        page.wait(lambda: page.shown("region-map-section"), "the map")
        page.step("pose-2")
        # The session's notes stay on one line until opened, and open whole on a click.
        notices = page.el("notices")
        one_line = notices.size["height"]
        assert "operator-noise" in page.text("notices")  # where the noise file is kept
        notices.click()
        page.wait(lambda: notices.size["height"] > 1.5 * one_line, "the notes opened")
        assert notices.get_attribute("aria-expanded") == "true"
        notices.click()
        page.wait(lambda: notices.size["height"] == one_line, "the notes on one line again")

        for testid, value in (("pose-x", "1.5"), ("pose-y", "0"), ("pose-z", "-1")):
            page.type(testid, value)
        page.el("capture").click()
        page.wait(lambda: page.el("accept").is_enabled(), "the capture to end")
        page.wait(lambda: page.shown("preview-result"), "the result before the decision")
        assert "trial 1 (2 views)" in page.text("preview-result")
        page.step("preview")

        page.el("accept").click()
        page.wait(lambda: "trial 2" in page.text("status"), "trial 2")
        page.wait(lambda: page.text("trial-result").startswith("trial 1"), "trial 1's result")
        legend = page.el("topview-legend")
        assert float(legend.value_of_css_property("font-size").removesuffix("px")) >= 12
        canvas = page.el("topview").rect
        assert legend.rect["y"] >= canvas["y"] + canvas["height"]  # not over the data
        page.step("trial-2")

        # Quit asks first; then the page says the session is finished, with the summary.
        page.el("quit").click()
        page.wait(lambda: page.shown("quit-confirm"), "the confirmation")
        page.step("quit-asked")
        page.el("quit-confirm").click()
        page.wait(lambda: page.shown("summary"), "the summary")
        assert "finished" in page.text("status")
        assert "1 trial (1 complete)" in page.text("summary")
        page.step("finished", recording=False)


# --------------------------------------------------------------------------- states by hand


def _missed(frame: int, reason: str, objects: int) -> dict[str, Any]:
    """A captured frame without the target, as the session's state holds it."""
    return {
        "frame": frame,
        "found": False,
        "centroid_px": [None, None],
        "theta_deg": None,
        "area_px": None,
        "eccentricity": None,
        "n_blobs": objects,
        "line": "",
        "reason": reason,
    }


#: A capture with the target in 1 of 3 frames, the result it would give (near-degenerate),
#: and the live result failing: states a synthetic session does not reach on demand.
_FOUND = {
    "frame": 2,
    "found": True,
    "centroid_px": [321.5, 240.25],
    "theta_deg": 12.5,
    "area_px": 151.0,
    "eccentricity": 0.31,
    "n_blobs": 2,
    "line": "line -0.216 u +0.976 v = 165.1",
    "reason": "",
}
_WARNING = "parallax 0.4 deg < 1 deg"
_FEW = {
    "phase": "recording",
    "method": "point",
    "units": "in",
    "waiting": "decision",
    "offers": ["redo", "accept_anyway", "undo"],
    "trial": 4,
    "pose": 2,
    "n_poses": 2,
    "capture": {"frame": 3, "n_frames": 3},
    "frames": [
        _missed(1, "no dark feature on a bright background", 0),
        _FOUND,
        _missed(3, "no candidate passes the shape test", 3),
    ],
    "average": {
        "found": True,
        "n_used": 1,
        "n_frames": 3,
        "centroid_px": [321.5, 240.25],
        "theta_deg": 12.5,
        "centroid_std_px": [0.0, 0.0],
    },
    "shortfall": "few",
    "preview": {
        "trial": 4,
        "status": "ok",
        "warning": _WARNING,
        "text": f"trial 4 (2 views): x 0.512 y 1.480 z 30.911 in; WARNING {_WARNING}",
    },
    "message": (
        "trial 4 pose 2: the target was found in only 1 of 3 frames: redo, accept anyway, "
        "undo or quit"
    ),
    "level": "warning",
    "live_error": "the live result failed (ValueError: a test's fault); the recording goes on",
    "poses": [
        {"pose": 1, "t": [0.0, 0.0, 0.0], "r_deg": [0.0, 0.0, 0.0], "state": "accepted"},
        {"pose": 2, "t": [0.25, 0.0, 0.0], "r_deg": [0.0, 0.0, 0.0], "state": "awaiting decision"},
    ],
}


@pytest.fixture
def by_hand(tmp_path: Path) -> Iterator[tuple[str, Any]]:
    """The console's app in this process, its session's state set by the test (nothing
    records: no recording thread is started)."""
    from recorder.console.state import ConsoleSession

    with _serving(ConsoleSession(tmp_path / "by-hand.mcap")) as served:
        yield served


@contextlib.contextmanager
def _serving(session: Any) -> Iterator[tuple[str, Any]]:
    """Serve ``session``'s page from this process (its URL and the session)."""
    import socket
    import threading

    import uvicorn

    from recorder.console.server import ConsoleOptions, console_app

    app = console_app(session, ConsoleOptions(source="synthetic", given={}))
    sock = socket.socket()
    sock.bind(("127.0.0.1", 0))
    sock.listen(16)
    server = uvicorn.Server(uvicorn.Config(app, log_level="warning", lifespan="on"))
    thread = threading.Thread(target=server.run, kwargs={"sockets": [sock]}, daemon=True)
    thread.start()
    try:
        yield f"http://127.0.0.1:{sock.getsockname()[1]}/", session
    finally:
        session.closing.set()  # the page's live-image stream ends, as when the server stops
        server.should_exit = True
        thread.join(timeout=10)
        sock.close()


@pytest.mark.slow
def test_states_a_synthetic_session_does_not_reach(by_hand: tuple[str, Any]) -> None:
    """Few frames found: accept anyway offered, accept off (the status does not offer it)
    and refused in words by its key; the result before the decision with its warning; a
    failing live result in amber; a failed session."""
    url, session = by_hand
    session.update(**_FEW, setup_fields=[])
    with headless_chromium(1366, 768) as browser:
        page = Steps(browser, _folder("states-1366x768"))
        browser.get(url)
        page.wait(lambda: page.shown("accept-anyway"), "accept anyway offered")
        assert page.el("accept-anyway").is_enabled()
        assert not page.el("accept").is_enabled()  # on exactly while the status offers it
        assert "fewer than half" in page.text("shortfall")
        assert "warned" in str(page.el("preview").get_attribute("class"))
        assert "WARNING parallax" in page.text("preview-result")
        assert page.shown("live-error")
        assert "a test's fault" in page.text("live-error")
        # Amber, not red: the live result failed, the recording goes on (red is for what
        # stops or refuses).
        amber = page.el("live-error").value_of_css_property("background-color")
        assert amber.startswith("rgba(255, 240, 207"), amber
        assert "1 of 3 frames" in page.text("pose-average")
        assert page.text("frames-table").count("not found") == 2
        assert "awaiting decision" in page.text("pose-list")
        page.step("few-found")

        ActionChains(browser).send_keys("a").perform()  # its key: refused in words
        page.wait(lambda: page.shown("refusal"), "accept refused")
        assert "accept anyway" in page.text("refusal")
        assert page.el("refusal").get_attribute("data-control") == "accept"
        page.step("accept-refused")

        session.update(phase="failed", waiting="", message="the camera stopped: a test")
        page.wait(lambda: page.shown("finished"), "the failure shown")
        assert "the camera stopped" in page.text("summary")
        assert "error" in str(page.el("status").get_attribute("class"))
        page.step("failed", recording=False)


# --------------------------------------------------------------------------- issue 44


#: What a phone's page must show without scrolling sideways: the page no wider than the
#: screen, and each of these (when shown) within its width.
NARROW = """
const [selectors] = arguments;
const problems = [];
const width = document.documentElement.clientWidth;
if (innerWidth !== width || document.documentElement.scrollWidth > width) {
  problems.push(`the page is ${document.documentElement.scrollWidth} px wide in ${width}`);
}
for (const selector of selectors) {
  for (const e of document.querySelectorAll(selector)) {
    if (!e.getClientRects().length) continue;
    const r = e.getBoundingClientRect();
    if (r.left < 0 || r.right > width + 0.5) problems.push(`${selector}: ${r.left}-${r.right}`);
  }
}
return problems;
"""


def _fits(page: Steps, size: tuple[int, int], name: str, selectors: list[str]) -> None:
    """At 390 px: nothing to scroll sideways to; at the laptop's size: everything in view."""
    if size[0] < 500:
        problems = page.browser.execute_script(NARROW, ["[data-testid=status]", *selectors])
        page.n += 1
        page.browser.save_screenshot(str(page.folder / f"{page.n:02d}-{name}.png"))
        assert not problems, f"{name} at {size}: {problems}"
    else:
        page.step(name, recording=name != "continuing")


_IN_VIEW = """
const r = document.querySelector(arguments[0]).getBoundingClientRect();
return r.top > -1 && r.top < window.innerHeight;
"""

_PIXELS = """
const c = document.getElementById("live-last");
const d = c.getContext("2d").getImageData(0, 0, c.width, c.height).data;
let bright = 0;
for (let i = 0; i < d.length; i += 4) bright = Math.max(bright, d[i], d[i + 1], d[i + 2]);
return [c.width, c.height, bright];
"""


@pytest.fixture(scope="module")
def continued(tmp_path_factory: pytest.TempPathFactory) -> tuple[Path, Path]:
    """A session with a stop rule (95% within 0.8 in) to continue, and its scene."""
    return small_session(tmp_path_factory.mktemp("continued"))


@pytest.mark.slow
@pytest.mark.parametrize("size", [(1366, 768), (390, 844)])
def test_computing_continuing_and_a_dead_recorder_are_said(
    size: tuple[int, int], continued: tuple[Path, Path], tmp_path: Path
) -> None:
    """Issue 44 (2, 7, 8), at the laptop's size and a phone's: while the next suggestion is
    computed the page says so (not "accept, redo, undo or quit", the pose not "awaiting
    decision"); a continuation's page says what it continues, the next trial, where each
    field comes from and the stop rule; after kill -9 the last frame stays under one
    caption and the status gives the command that salvages the file."""
    from recorder.console.state import ConsoleSession

    session_file, scene = continued
    with headless_chromium(*size) as browser:
        if size[0] < 500:
            emulate_phone(browser, *size)
        page = Steps(browser, _folder(f"issue44-{size[0]}x{size[1]}"))
        decided = [{"pose": 1, "t": [0.0, 0.0, 0.0], "r_deg": [0.0, 0.0, 0.0], "state": "accepted"}]
        busy = ConsoleSession(tmp_path / "busy.mcap")
        with _serving(busy) as (url, session):
            computing = "trial 4 pose 1 accepted: computing the trial's result and the next "
            session.update(**{
                **_FEW, "live_error": "", "preview": None, "shortfall": "ok", "waiting": "",
                "pose": 1, "poses": decided, "setup_fields": [],
                "message": "trial 4 (1 view): no result yet",
                "computing": computing + "pose to suggest; the form comes back when it is done",
            })  # fmt: skip
            browser.get(url)
            page.wait(lambda: "computing" in page.text("status"), "computing said")
            assert "accept, redo" not in page.text("status")
            assert "computing the next pose to suggest" in page.text("guidance")
            assert "awaiting" not in page.text("pose-list")
            assert "accepted" in page.text("pose-list")
            assert not page.el("accept").is_enabled()
            shown = ["#operator-col", "[data-testid=accept]", "[data-testid=guidance]"]
            _fits(page, size, "computing", shown)

        out = tmp_path / "S2.mcap"
        process, url, _ = start_console(
            out, "--source", f"synthetic:{scene}", "--continue", str(session_file),
            "--operator", "eve",
        )  # fmt: skip
        try:
            browser.get(url)
            page.wait(lambda: browser.find_elements(By.ID, "f-target_precision"), "the form")
            assert "Continuing S.mcap; the next trial is 2" in page.text("status")
            assert page.text("from-method") == "from S.mcap (the session's setup, fixed)"
            assert page.text("from-truth1") == "from S.mcap (the session's setup, fixed)"
            assert "from the command line" in page.text("from-operator")
            assert page.el("field-operator").get_attribute("value") == "eve"
            assert page.el("field-target_precision").get_attribute("value") == "0.8"
            assert "from S.mcap: its stop rule" in page.text("from-target_precision")
            _fits(page, size, "continuing", ["#setup", "[data-testid=setup-submit]"])
            page.el("setup-submit").click()
            page.wait(lambda: "trial 2: type pose 1" in page.text("status"), "trial 2")
            said = page.text("session-setup")
            assert "stop rule a trial is complete once its 95% region is within 0.8 in" in said
            assert "continues S.mcap after trial 1" in said
            assert "operator eve" in said
            page.wait(lambda: browser.execute_script(_PIXELS)[0] == 320, "a frame kept")
            # The operator scrolled down to the buttons (a phone): the death is brought into view.
            browser.execute_script("window.scrollTo(0, document.body.scrollHeight)")
            process.send_signal(signal.SIGKILL)
            process.wait(timeout=10)
            page.wait(lambda: "the recorder stopped" in page.text("status"), "the death said")
            assert f"twopose-record recover {out} -o FIXED.mcap" in page.text("status")
            assert browser.execute_script(_IN_VIEW, "[data-testid=status]"), "status scrolled off"
            time.sleep(0.6)  # the stream's image has gone by now, on a page that lost it
            assert page.shown("live-last")
            assert not page.shown("live-image")
            width, height, bright = browser.execute_script(_PIXELS)
            assert (width, height) == (320, 240)
            assert bright > 60, "the last frame is black"
            assert page.text("live-caption") == "the last frame before the recorder stopped"
            assert not page.shown("live-note")  # never "waiting for the camera's first frame"
            _fits(page, size, "crashed", ["[data-testid=live-caption]", "[data-testid=accept]"])
        finally:
            if process.poll() is None:
                process.kill()
            process.communicate(timeout=30)
