"""The console never misleads, in a real headless Chromium at 1366x768, one walk per
method (board included): every setup refusal at once, the setup in view while recording,
a line's angle error beside its distance error, no preview of what cannot be accepted and
no code words, a board found frame by frame with the rig's readiness and the board in the
top view, notes listed and the keys deciding after one, and a recorder that stops said as
stopped with its controls off. Screenshots go to the test's folder."""

from __future__ import annotations

import signal
from pathlib import Path

import pytest

from tests.browser import headless_chromium, require_chromium
from tests.helpers import start_console
from tests.recorder.test_console_browser import Page

require_chromium()

from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import Select  # noqa: E402

pytestmark = pytest.mark.slow

SETUPS = {
    "point": {"field-truth1": "0.5, 1.5, 11"},
    # The scene's line stands upright; the typed truth is tilted 35 degrees off it.
    "line": {"field-truth1": "1.91, 9.625, 8.375", "field-truth2": "1.91, 1.4, 20.1"},
    "ground": {"field-ground_height": "9.625", "field-truth1": "1.91, 9.625, 8.375"},
    "board": {"field-board": "9x6", "field-square": "1", "field-board_corner": "-3, 8.125, 24"},
}
CODE_WORDS = ("no_detection", "degenerate:", "incomplete:", "NONE_FOUND", "undefined", "NaN")


def _visible_errors(page: Page) -> list[str]:
    script = (
        "return [...document.querySelectorAll('.field-error')]"
        ".filter((e) => e.getClientRects().length).map((e) => e.id)"
    )
    return [str(e) for e in page.browser.execute_script(script)]


def _setup(page: Page, method: str) -> None:
    """A setup with three faults, refused at once; then the right one."""
    page.wait(lambda: page.browser.find_elements(By.ID, "f-method"), "the setup form")
    # Before a method is chosen: only what every method asks.
    assert not page.el("field-ground_height").is_displayed()
    assert not page.el("field-board").is_displayed()
    Select(page.browser.find_element(By.ID, "f-method")).select_by_visible_text(method)
    page.type("field-focal", "-5")
    assert not page.browser.find_element(By.ID, "default-focal").is_displayed()
    page.type("field-operator", "A" * 120)
    first = next(iter(SETUPS[method]))
    page.type(first, "1, 2")
    page.click("setup-submit")
    page.wait(lambda: len(_visible_errors(page)) >= 3, "every refusal at once")
    assert {"error-focal", "error-operator", "error-" + first[6:]} <= set(_visible_errors(page))
    page.type("field-focal", "525")
    page.type("field-operator", "Ada")
    for testid, text in SETUPS[method].items():
        page.type(testid, text)
    page.click("setup-submit")
    page.wait(lambda: "type pose 1" in page.status(), "the first pose")


def _no_code_words(page: Page) -> None:
    text = str(page.browser.execute_script("return document.body.innerText"))
    for word in CODE_WORDS:
        assert word not in text, word


@pytest.mark.parametrize("method", ["point", "line", "ground", "board"])
def test_one_trial_per_method_tells_the_truth(method: str, tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    process, url, _ = start_console(out)
    try:
        with headless_chromium(1366, 768) as browser:
            browser.get(url)
            page = Page(browser)
            _setup(page, method)
            shown = page.text("session-setup")
            assert f"method {method}" in shown
            assert "units in" in shown
            assert "f 525 px" in shown
            assert ("board 9x6 inner corners" if method == "board" else "ground truth (") in shown

            # A pose facing away: nothing found, accept off, no preview, no code words.
            page.wait(lambda: page.el("pose-x").is_enabled(), "the pose form")
            page.type("pose-x", "0")
            page.type("pose-y", "0")
            page.type("pose-z", "0")
            page.type("pose-rotation", "0, 180, 0")
            page.click("capture")
            page.wait(lambda: page.el("redo").is_enabled(), "the capture to end")
            assert not page.el("accept").is_enabled()
            assert not page.el("preview").is_displayed()
            assert "not found in any frame" in page.text("shortfall")
            _no_code_words(page)
            browser.save_screenshot(str(tmp_path / f"{method}-away.png"))
            page.click("redo")

            page.capture("0", "0")
            if method == "board":
                assert "board found: 54 corners, covering" in page.text("frames-table")
            page.click("accept")
            page.capture("1.5", "-1")
            page.type("note-text", "lamp flickered")
            page.click("note-add")
            page.wait(lambda: "trial 1: lamp flickered" in page.text("notes-list"), "the note")
            # The keys decide again: "a" accepts, it does not type into the note box.
            active = browser.execute_script("return document.activeElement.id")
            assert active != "note-text"
            browser.find_element(By.TAG_NAME, "body").send_keys("a")
            page.wait(lambda: "trial 2" in page.status(), "accepted by its key")
            assert page.el("note-text").get_attribute("value") == ""
            _check_result(page, method)
            _no_code_words(page)
            browser.save_screenshot(str(tmp_path / f"{method}-trial.png"))

            process.send_signal(signal.SIGINT)
            process.wait(timeout=60)
            # Ctrl-C closes the file: the page says so if the last state reached it before
            # the server went, else it cannot tell a stop from a crash and gives the recover
            # command (harmless after Ctrl-C). Which one is a race; both are true.
            page.wait(
                lambda: (
                    "the recorder stopped" in page.status()
                    or "the recorder has stopped: the file is closed" in page.status()
                ),
                "the recorder stopped",
            )
            assert "stopped" in str(
                browser.find_element(By.TAG_NAME, "body").get_attribute("class")
            )
            assert not page.el("capture").is_enabled()
            assert not page.el("quit").is_enabled()
            if "the file is closed" not in page.status():
                assert "twopose-record recover " in page.status()  # what salvages it
                assert page.text("live-caption") == "the last frame before the recorder stopped"
            browser.save_screenshot(str(tmp_path / f"{method}-stopped.png"))
    finally:
        if process.poll() is None:
            process.terminate()
        process.communicate(timeout=30)


def _check_result(page: Page, method: str) -> None:
    """What the results column shows once trial 1 is accepted."""
    if method == "board":
        assert not page.el("trials").is_displayed()  # no trial results on a board session
        assert "cannot determine the rig yet" in page.text("rig-readiness")
        assert "at least 3 captures" in page.text("rig-readiness")
        assert "the board (its inner corners" in page.text("topview-legend")
        return
    page.wait(lambda: len(page.results()) == 1, "trial 1's result")
    (text,) = page.results()
    if method == "line":
        assert "angle error" in text
        assert "deg" in text
        assert "distance error" in text
        assert "beyond its 95% region" in text  # the typed truth is 35 degrees off
        item = page.browser.find_element(By.CSS_SELECTOR, "[data-testid=trial-result]")
        assert "warned" in str(item.get_attribute("class"))
    else:
        assert "95% within" in text
