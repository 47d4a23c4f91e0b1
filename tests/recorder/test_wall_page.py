"""A method on another plane, in the browser (issue 45): with the wall's extension
installed (:mod:`tests.test_wall_method`), the console records a session in
the web console, in a real headless Chromium at a laptop's size. The page asks the wall's
x by the plane's own label (it never names a method or a plane), refuses a ground truth
off the wall by its field, and the session it records is analysed on the wall."""

from __future__ import annotations

import os
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.browser import headless_chromium, require_chromium
from tests.helpers import read_line_when_printed
from tests.recorder.test_console_browser import Page
from tests.test_wall_method import TRUTH, WALL_X, add_the_wall, analysed, assert_on_the_wall

require_chromium()

from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import Select  # noqa: E402

# Slow: a real browser (make test-all and CI run it).
pytestmark = pytest.mark.slow


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    with headless_chromium(1366, 768) as driver:
        yield driver


def _start(root: Path, out: Path) -> tuple[subprocess.Popen[str], str]:
    """``new --ui`` with the wall installed and its scene; the process and its URL."""
    env = {**os.environ, "PYTHONPATH": str(root), "NO_COLOR": "1"}
    process = subprocess.Popen(
        [sys.executable, "-m", "recorder", "new", str(out), "--ui", "--source",
         "synthetic:wall_scene.toml", "--frames", "2", "--units", "in", "--focal", "525",
         "--principal", "320,240", "--operator", "Bo"],
        cwd=root, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    line, _ = read_line_when_printed(process, "http://", "the console's address")
    return process, line.split()[2]


def test_the_wall_method_is_recorded_in_the_browser(
    browser: Any, tmp_path_factory: pytest.TempPathFactory
) -> None:
    root = add_the_wall(tmp_path_factory.mktemp("wall_page"))
    out = root / "page.mcap"
    process, url = _start(root, out)
    try:
        browser.get(url)
        page = Page(browser)
        page.wait(lambda: browser.find_elements(By.ID, "f-method"), "the setup form")
        Select(browser.find_element(By.ID, "f-method")).select_by_value("wall")
        page.wait(lambda: page.el("field-wall_x").is_displayed(), "the wall's x field")
        assert not browser.find_elements(By.CSS_SELECTOR, "[data-testid=field-ground_height]") or (
            not page.el("field-ground_height").is_displayed()
        )
        assert "wall: its x on the grid" in browser.find_element(By.ID, "setup").text
        # A truth off the wall is refused by its field, nothing recorded.
        page.type("field-wall_x", str(WALL_X))
        page.type("field-truth1", "1.91, 9.625, 8.375")
        page.click("setup-submit")
        page.wait(lambda: "the wall is at x = 9.625" in page.text("field-error-truth1"), "off")
        assert not out.exists()
        page.type("field-truth1", ", ".join(str(v) for v in TRUTH))
        page.click("setup-submit")
        page.wait(lambda: "type pose 1" in page.status(), "the first pose")
        page.capture("0", "0")
        page.click("accept")
        page.capture("3", "0")
        page.click("accept")
        page.wait(lambda: len(page.results()) == 1, "the trial's result")
        browser.save_screenshot(str(root / "wall_page.png"))
        # The page's words are the wall's spec's (its MethodPage), none of the ground's.
        body = browser.find_element(By.TAG_NAME, "body").text
        assert "wall point (estimate)" in body
        assert "wall's x 9.625 in" in body
        assert "on the ground" not in body
        page.click("quit")
        page.click("quit-confirm")
        summary = browser.find_element(By.ID, "summary")
        page.wait(lambda: "1 trial (1 complete)" in summary.text, "the summary")
    finally:
        process.terminate()
        process.wait(timeout=30)
    assert_on_the_wall(analysed(root, out), 1, within=0.5)
