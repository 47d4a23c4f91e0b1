"""The web console in a real headless Chromium (Debian's chromium and chromium-driver,
Selenium): a whole synthetic-source session from setup to quit, with bad input in every
field, a redo, an undo, a note and a reload; the page's results are the analysis'."""

from __future__ import annotations

import io
from collections.abc import Callable, Iterator
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np
import pandas as pd
import pytest
from PIL import Image

import analysis
from tests.browser import headless_chromium, require_chromium
from tests.helpers import start_console

require_chromium()

from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import Select, WebDriverWait  # noqa: E402

# Slow (a real browser, a cluster, or fits over many sessions): make test-all and CI run it.
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    with headless_chromium(1280, 1000) as driver:
        yield driver


class Page:
    """The console's elements by their data-testid, and waits on what the page shows."""

    def __init__(self, browser: Any) -> None:
        self.browser = browser

    def el(self, testid: str) -> Any:
        return self.browser.find_element(By.CSS_SELECTOR, f"[data-testid={testid}]")

    def type(self, testid: str, text: str) -> None:
        element = self.el(testid)
        element.clear()
        element.send_keys(text)

    def click(self, testid: str) -> None:
        # Shown as well as enabled: the page shows a panel once its state has arrived (on a
        # loaded machine the button exists, hidden, before that: "element not interactable").
        self.wait(
            lambda: self.el(testid).is_displayed() and self.el(testid).is_enabled(),
            f"{testid} shown and enabled",
        )
        self.el(testid).click()

    def status(self) -> str:
        return str(
            self.browser.execute_script(
                "return document.querySelector('[data-testid=status]').textContent"
            )
        )

    def wait(self, condition: Callable[[], object], what: str, timeout: float = 60) -> None:
        WebDriverWait(self.browser, timeout).until(lambda _: condition(), message=what)

    def results(self) -> list[str]:
        """The trial results' texts (read in one script: the list is redrawn as it polls)."""
        texts = self.browser.execute_script(
            "return [...document.querySelectorAll('[data-testid=trial-result]')]"
            ".map((e) => e.textContent)"
        )
        return [str(t) for t in texts]

    def text(self, testid: str) -> str:
        script = "const e = document.querySelector(arguments[0]); return e ? e.textContent : ''"
        return str(self.browser.execute_script(script, f"[data-testid={testid}]"))

    def capture(self, x: str, z: str) -> None:
        """Type a pose in the empty form (a new pose's form is empty) and capture it."""
        self.wait(lambda: self.el("pose-x").is_enabled(), "the pose form")
        self.type("pose-x", x)
        self.type("pose-y", "0")
        self.type("pose-z", z)
        self.type("pose-rotation", "0, 0, 0")
        self.click("capture")
        self.wait(lambda: self.el("accept").is_enabled(), "the capture to end")

    def shot(self) -> np.ndarray:
        return np.asarray(Image.open(io.BytesIO(self.browser.get_screenshot_as_png())))


def _shows(page: Page, testid: str, text: str) -> bool:
    return text in page.text(testid)


def test_a_whole_session_in_the_browser(browser: Any, tmp_path: Path) -> None:
    out = tmp_path / "ui.mcap"
    process, url, _ = start_console(out)
    try:
        browser.get(url)
        page = Page(browser)
        page.wait(lambda: browser.find_elements(By.ID, "f-method"), "the setup form")
        # Bad setup input: every refusal at once, each by its field; nothing starts.
        Select(browser.find_element(By.ID, "f-method")).select_by_visible_text("point")
        page.type("field-focal", "abc")
        page.type("field-truth1", "0.5, 1.5")
        page.click("setup-submit")
        page.wait(lambda: page.text("field-error-truth1") != "", "the truth refused")
        assert "'abc' is not a number" in page.text("field-error-focal")
        assert "type 3 numbers" in page.text("field-error-truth1")
        assert not out.exists()  # nothing recorded yet
        page.type("field-focal", "525")
        page.type("field-truth1", "0.5, 1.5, 11")
        page.type("field-operator", "Ada")
        page.click("setup-submit")
        page.wait(lambda: "type pose 1" in page.status(), "the first pose")
        first_screen = page.shot()

        # Bad pose input in every field: refused by its field, the pose still awaited.
        page.wait(lambda: page.el("pose-x").is_enabled(), "the pose form")
        for testid, bad, expected in (
            ("x", "abc", "camera centre x: 'abc' is not a number"),
            ("y", "1e9", "camera centre y must be from -200 to 200 in, got 1e9"),
            ("z", "", "camera centre z: type a number"),
            ("rotation", "0, 0, 999", "must be from -180 to 180 deg"),
        ):
            page.type("pose-x", "0")
            page.type("pose-y", "0")
            page.type("pose-z", "0")
            page.type("pose-rotation", "0, 0, 0")
            page.type(f"pose-{testid}", bad)
            page.click("capture")
            page.wait(partial(_shows, page, f"field-error-{testid}", expected), bad)
            assert page.el("capture").is_enabled()

        # Trial 1: pose 1, then pose 2 redone once.
        page.capture("0", "0")
        live = browser.find_element(By.CSS_SELECTOR, "[data-testid=live-image]")
        assert browser.execute_script("return arguments[0].naturalWidth", live) == 640
        page.click("accept")
        page.capture("1.5", "-1")
        page.click("redo")
        page.capture("1.5", "-1")
        page.click("accept")
        page.wait(lambda: len(page.results()) == 1, "trial 1's result")
        # A reload mid-session: the page reconnects to the running session.
        browser.refresh()
        page.wait(lambda: len(page.results()) == 1 and "trial 2" in page.status(), "reconnect")

        # Trial 2: pose 2 undone (back to pose 1), a note, then done.
        page.capture("-1", "0")
        page.click("accept")
        page.capture("1", "0.5")
        page.click("undo")
        page.wait(lambda: "pose 1" in page.status(), "back to pose 1")
        # The form shows pose 1 as typed, to retype; pose 2's values are gone.
        page.wait(lambda: page.el("pose-x").is_enabled(), "the pose form")
        assert browser.find_element(By.ID, "pose-x").get_attribute("value") == "-1"
        page.capture("-1", "0")
        page.click("accept")
        page.capture("1", "0.5")
        page.type("note-text", "lamp flickered")
        page.click("note-add")
        page.wait(lambda: "note added" in page.status(), "the note")
        page.click("accept")
        page.wait(lambda: len(page.results()) == 2, "trial 2's result")
        shown = page.results()
        page.click("quit")
        page.click("quit-confirm")
        summary = browser.find_element(By.ID, "summary")
        page.wait(lambda: "2 trials (2 complete)" in summary.text, "the summary")
        last_screen = page.shot()
    finally:
        process.terminate()
        process.wait(timeout=30)

    # What the page showed is what the analysis finds, to the printed precision.
    result = analysis.run([out], tmp_path / "results", scene=False)
    trials = result.trials.set_index("trial")
    assert list(trials["status"]) == ["ok", "ok"]
    for text, (trial, row) in zip(shown, trials.iterrows(), strict=True):
        assert text.startswith(f"trial {trial} (2 views)")
        assert f"x {row['x']:.3f} y {row['y']:.3f} z {row['z']:.3f} in" in text
        assert f"error {row['err']:.3f} in" in text
    notes = pd.read_csv(tmp_path / "results" / "trials.csv", keep_default_na=False)["notes"]
    assert list(notes) == ["", "lamp flickered"]
    # The screens were drawn: ink on them, and they changed as the session went on.
    assert (first_screen[..., :3] < 128).mean() > 0.01
    assert np.abs(first_screen.astype(int) - last_screen.astype(int)).mean() > 1


def test_the_setup_shows_what_the_command_line_gave(browser: Any, tmp_path: Path) -> None:
    """Given options are shown read-only, marked as such; only the method's fields."""
    out = tmp_path / "given.mcap"
    process, url, _ = start_console(out, "--method", "ground", "--ground-height", "9.5")
    try:
        browser.get(url)
        page = Page(browser)
        page.wait(lambda: browser.find_elements(By.ID, "f-method"), "the setup form")
        method = browser.find_element(By.ID, "f-method")
        assert method.get_attribute("value") == "ground"
        assert not method.is_enabled()
        height = browser.find_element(By.ID, "f-ground_height")
        assert height.get_attribute("value") == "9.5"
        assert height.get_attribute("readonly") is not None
        cell = browser.find_element(By.ID, "cell-ground_height")
        assert "from the command line" in cell.text
        assert not browser.find_element(By.ID, "cell-truth2").is_displayed()
        assert browser.find_element(By.ID, "cell-keep_off_ground").is_displayed()
        assert browser.find_element(By.ID, "f-focal").get_attribute("value") == "525"
    finally:
        process.terminate()
        process.wait(timeout=30)


def test_a_board_session_in_the_browser(browser: Any, tmp_path: Path) -> None:
    """The board's fields, and no ground truth, for a board session; a board that is no
    board is refused by its fields; three poses typed (``--poses 3``) into a board session
    that the rig calibration reads."""
    from analysis.rig.board import read_board_session
    from twopose.format.reader import SessionReader

    out = tmp_path / "board.mcap"
    process, url, _ = start_console(out, "--poses", "3")
    try:
        browser.get(url)
        page = Page(browser)
        page.wait(lambda: browser.find_elements(By.ID, "f-method"), "the setup form")
        Select(browser.find_element(By.ID, "f-method")).select_by_visible_text("board")
        assert browser.find_element(By.ID, "cell-board").is_displayed()
        assert browser.find_element(By.ID, "cell-board_corner").is_displayed()
        assert not browser.find_element(By.ID, "cell-truth1").is_displayed()
        page.type("field-board", "9 by 6")
        page.type("field-board_corner", "-3, 8.125")
        page.click("setup-submit")
        page.wait(lambda: page.text("field-error-board") != "", "the board refused")
        assert "COLSxROWS" in page.text("field-error-board")
        assert "type a number" in page.text("field-error-square")
        assert "type 3 numbers" in page.text("field-error-board_corner")
        assert not out.exists()
        page.type("field-board", "9x6")
        page.type("field-square", "0.75")
        page.type("field-board_corner", "-3, 8.125, 24")
        page.click("setup-submit")
        page.wait(lambda: "type pose 1 of 3" in page.status(), "the first pose")
        for x, z in (("0", "0"), ("2", "0"), ("0", "-2")):
            page.capture(x, z)
            page.click("accept")
        page.wait(lambda: "trial 2" in page.status(), "the next trial")
        page.click("quit")
        page.click("quit-confirm")
        summary = browser.find_element(By.ID, "summary")
        page.wait(lambda: "1 trial (1 complete)" in summary.text, "the summary")
    finally:
        process.terminate()
        process.wait(timeout=30)
    with SessionReader(out) as reader:
        assert reader.info.board is not None
        assert reader.info.board.first_corner == (-3.0, 8.125, 24.0)
    assert read_board_session(out).observed_px.shape == (3, 54, 2)


def test_the_console_suggests_the_next_pose_and_stops_by_the_rule(tmp_path: Path) -> None:
    """Issue 36 in the browser at a laptop's 1366x768: after pose 1 the page shows the
    suggested next pose, ``g`` in the pose form takes it, the top view marks the next one,
    and with --target-precision a trial ends as soon as its region is within it."""
    from tests.doc_images import CONSOLE_VOLATILE, doc_image, live_frame_drawn

    out = tmp_path / "guided.mcap"
    process, url, _ = start_console(out, "--target-precision", "1.0", "--max-poses", "4")
    try:
        with headless_chromium(1366, 768) as laptop:
            laptop.get(url)
            page = Page(laptop)
            page.wait(lambda: laptop.find_elements(By.ID, "f-method"), "the setup form")
            Select(laptop.find_element(By.ID, "f-method")).select_by_visible_text("point")
            page.type("field-truth1", "0.5, 1.5, 11")
            page.type("field-operator", "Ada")
            page.click("setup-submit")
            page.capture("0", "0")
            page.click("accept")
            page.wait(lambda: "next pose:" in page.text("guidance-text"), "a suggestion")
            said = page.text("guidance-text")
            assert "one pose cannot locate the target yet" in said
            # Issue 46: the map under the top view, its cells painted (green: the good
            # ones), its scale and its three best listed; after one pose (issue 55) each
            # cell's worst regret over the depths, as the suggestion weighs them.
            page.wait(lambda: page.el("region-map-section").is_displayed(), "the map")
            painted = laptop.execute_script(
                "const c = document.getElementById('regionmap');"
                "const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
                "let n = 0; for (let k = 0; k < d.length; k += 4)"
                " if (d[k + 1] > d[k] + 20 && d[k + 1] > d[k + 2] + 20) n++; return n;"
            )
            assert painted > 500
            assert "worst regret, a target 8-30 in away" in page.text("region-map-section")
            assert "(best)" in page.text("region-map-scale")
            poses = laptop.find_elements(By.CSS_SELECTOR, "[data-testid=region-map-pose]")
            assert len(poses) == 3
            page.wait(lambda: page.el("pose-x").is_enabled(), "the pose form")
            page.el("pose-x").send_keys("g")  # one key takes the suggestion into the form
            suggested = [page.el(f"pose-{axis}").get_attribute("value") for axis in "xyz"]
            assert f"x {suggested[0]}, y {suggested[1]}, z {suggested[2]} in" in said
            page.click("capture")
            page.wait(lambda: page.el("accept").is_enabled(), "the capture to end")
            page.click("accept")
            page.wait(lambda: "trial 1 (2 views)" in " ".join(page.results()), "the result")
            page.wait(
                lambda: (
                    "next pose:" in page.text("guidance-text")
                    or "trial complete" in page.text("guidance-text")
                ),
                "the next advice",
            )
            if "next pose:" in page.text("guidance-text"):
                legend = laptop.find_element(By.ID, "topview-legend").text
                assert "suggested next pose" in legend
                # The map follows the suggestion: the picture waits for it.
                page.wait(lambda: page.el("region-map-section").is_displayed(), "the map")
                png = laptop.get_screenshot_as_png()
                # The top view's scale follows the poses the run took, which a loaded
                # machine's timing can change (the picture is of the map and the advice).
                volatile = (*CONSOLE_VOLATILE, "#topview")
                problem = live_frame_drawn(laptop, png)
                assert not problem, problem
                doc_image("console-suggestion.png", png, driver=laptop, volatile=volatile)
                page.el("pose-x").send_keys("g")
                page.click("capture")
                page.wait(lambda: page.el("accept").is_enabled(), "the capture to end")
                page.click("accept")
            page.wait(lambda: "trial 2: type pose 1" in page.status(), "the stop rule")
            # How trial 1 ended stays said until trial 2's first pose.
            assert "trial 1: " in page.status()
            assert "trial complete" in page.status()
    finally:
        process.terminate()
        process.wait(timeout=30)
    assert out.exists()


def test_a_session_continued_in_the_browser(browser: Any, tmp_path: Path) -> None:
    """Issue 36: ``--ui --continue S.mcap``: the setup is the session's, read-only; the
    page's trial is numbered after S's last; run sees one session."""
    from recorder.setup.plan import load_plan, record_plan
    from recorder.sources.registry import SyntheticSource
    from tests.recorder.test_continuation import _plan
    from twopose.format.reader import SessionReader
    from twopose.methods.specs import Method

    first, later = tmp_path / "S.mcap", tmp_path / "S2.mcap"
    record_plan(load_plan(_plan(tmp_path, "a.toml", 2)), first,
                SyntheticSource(None, Method.GROUND, realtime=False))  # fmt: skip
    process, url, _ = start_console(later, "--continue", str(first))
    try:
        browser.get(url)
        page = Page(browser)
        page.wait(lambda: browser.find_elements(By.ID, "f-method"), "the setup form")
        method = browser.find_element(By.ID, "f-method")
        assert method.get_attribute("value") == "ground"
        assert not method.is_enabled()
        height = browser.find_element(By.ID, "f-ground_height")
        assert height.get_attribute("value") == "9.625"
        assert height.get_attribute("readonly") is not None
        page.click("setup-submit")
        page.wait(lambda: "trial 3" in page.status(), "trial 3, after the session's two")
        page.capture("0", "0")
        page.click("accept")
        page.capture("1.5", "0")
        page.click("accept")
        page.wait(lambda: any("trial 3 (2 views)" in r for r in page.results()), "its result")
        page.click("quit")
        page.click("quit-confirm")
        page.wait(lambda: "wrote" in page.text("summary"), "the summary")
    finally:
        process.terminate()
        process.wait(timeout=30)
    with SessionReader(first) as a, SessionReader(later) as b:
        assert b.info.session_id == a.info.session_id
        assert b.info.continues_after_trial == 2
    trials = analysis.run([later, first], None).trials
    assert list(trials["trial"]) == [1, 2, 3]
