"""The web console in a real headless Chromium (Debian's chromium and chromium-driver,
Selenium): a whole synthetic-source session from setup to quit, with bad input in every
field, a redo, an undo, a note and a reload; the page's results are the analysis'."""

from __future__ import annotations

import io
from collections.abc import Iterator
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


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    with headless_chromium(1280, 1000) as driver:
        yield driver


class Page:
    """The console's elements by their data-testid, and waits on what the page shows."""

    def __init__(self, browser: Any) -> None:
        self.browser = browser

    def el(self, testid: str) -> object:
        return self.browser.find_element(By.CSS_SELECTOR, f"[data-testid={testid}]")

    def type(self, testid: str, text: str) -> None:
        element = self.el(testid)
        element.clear()  # type: ignore[attr-defined]
        element.send_keys(text)  # type: ignore[attr-defined]

    def click(self, testid: str) -> None:
        self.wait(lambda: self.el(testid).is_enabled(), f"{testid} enabled")  # type: ignore[attr-defined]
        self.el(testid).click()  # type: ignore[attr-defined]

    def status(self) -> str:
        return str(
            self.browser.execute_script(
                "return document.querySelector('[data-testid=status]').textContent"
            )
        )

    def wait(self, condition: object, what: str, timeout: float = 60) -> None:
        WebDriverWait(self.browser, timeout).until(
            lambda _: condition(),
            message=what,  # type: ignore[operator]
        )

    def results(self) -> list[str]:
        """The trial results' texts (read in one script: the list is redrawn as it polls)."""
        texts = self.browser.execute_script(
            "return [...document.querySelectorAll('[data-testid=trial-result]')]"
            ".map((e) => e.textContent)"
        )
        return [str(t) for t in texts]

    def capture(self, x: str, z: str) -> None:
        self.type("pose-x", x)
        self.type("pose-y", "0")
        self.type("pose-z", z)
        self.type("pose-rotation", "0, 0, 0")
        self.click("capture")
        self.wait(lambda: self.el("accept").is_enabled(), "the capture to end")  # type: ignore[attr-defined]

    def shot(self) -> np.ndarray:
        return np.asarray(Image.open(io.BytesIO(self.browser.get_screenshot_as_png())))


def test_a_whole_session_in_the_browser(browser: Any, tmp_path: Path) -> None:
    out = tmp_path / "ui.mcap"
    process, url, _ = start_console(out)
    try:
        browser.get(url)
        page = Page(browser)
        page.wait(lambda: page.el("setup-submit").is_displayed(), "the setup form")  # type: ignore[attr-defined]
        # Bad setup input: refused with the reason, nothing starts.
        Select(browser.find_element(By.ID, "f-method")).select_by_visible_text("point")
        browser.find_element(By.ID, "f-focal").send_keys("abc")
        browser.find_element(By.ID, "f-truth1").send_keys("0.5, 1.5")
        page.click("setup-submit")
        page.wait(lambda: page.status().startswith("refused: focal"), "the focal refused")
        browser.find_element(By.ID, "f-focal").clear()
        page.click("setup-submit")
        page.wait(lambda: "truth1" in page.status(), "the truth refused")
        assert not out.exists()  # nothing recorded yet
        browser.find_element(By.ID, "f-truth1").clear()
        browser.find_element(By.ID, "f-truth1").send_keys("0.5, 1.5, 11")
        browser.find_element(By.ID, "f-operator").send_keys("Ada")
        page.click("setup-submit")
        page.wait(lambda: "type pose 1" in page.status(), "the first pose")
        first_screen = page.shot()

        # Bad pose input in every field: refused, the pose still awaited.
        for testid, bad, expected in (
            ("pose-x", "abc", "translation"),
            ("pose-y", "1e9", "implausibly large"),
            ("pose-z", "", "translation"),
            ("pose-rotation", "0, 0, 999", "rotation"),
        ):
            page.type("pose-x", "0")
            page.type("pose-y", "0")
            page.type("pose-z", "0")
            page.type("pose-rotation", "0, 0, 0")
            page.type(testid, bad)
            page.click("capture")
            page.wait(lambda e=expected: "refused" in page.status() and e in page.status(), bad)
            assert page.el("capture").is_enabled()  # type: ignore[attr-defined]

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
