"""report.html in a real headless Chromium (Debian's ``chromium`` and ``chromium-driver``,
driven by Selenium): at a 1280 px window nothing overflows, every image loads and the
answer comes first. ``.ci/run`` installs the browser; elsewhere the test is skipped when
it is missing (and fails in CI, where it must run)."""

from __future__ import annotations

import io
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image

from tests.browser import headless_chromium, require_chromium

require_chromium()

from selenium.webdriver.common.by import By  # noqa: E402

WIDTH, HEIGHT = 1280, 900


@pytest.fixture(scope="module")
def report(bundled_run: Path) -> Path:
    """The report of ``make run``: the bundled sample sessions."""
    return bundled_run / "report.html"


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    with headless_chromium(WIDTH, HEIGHT) as driver:
        yield driver


def test_report_fits_a_1280_px_window_and_every_image_loads(report: Path, browser: Any) -> None:
    browser.get(report.as_uri())
    inner_width = browser.execute_script("return window.innerWidth")
    page_width = browser.execute_script(
        "return Math.max(document.documentElement.scrollWidth, document.body.scrollWidth)"
    )
    assert inner_width <= WIDTH
    assert page_width <= inner_width, f"the page is {page_width} px wide in {inner_width} px"

    images = browser.find_elements(By.TAG_NAME, "img")
    assert len(images) >= 8  # 3 overview + sensitivity + the sessions' figures
    for image in images:
        loaded = browser.execute_script(
            "return arguments[0].complete && arguments[0].naturalWidth > 0", image
        )
        assert loaded, image.get_attribute("alt")
        assert image.rect["x"] + image.rect["width"] <= inner_width + 1

    # Every wide table scrolls inside its own box, which stays inside the window.
    boxes = browser.find_elements(By.CSS_SELECTOR, "div.scroll")
    assert boxes
    assert all(box.rect["x"] + box.rect["width"] <= inner_width + 1 for box in boxes)


def test_report_answers_first(report: Path, browser: Any) -> None:
    browser.get(report.as_uri())
    headings = [h.text for h in browser.find_elements(By.CSS_SELECTOR, "h2")]
    assert headings[0] == "Answer per method"
    answer = browser.find_element(By.CSS_SELECTOR, "#answer + p + div table")
    header = [th.text for th in answer.find_elements(By.CSS_SELECTOR, "thead th")]
    assert {"method", "rmse", "median_err", "bias_x_ci95", "n_warned", "coverage95"} <= set(header)
    methods = [
        row.find_element(By.TAG_NAME, "td").text
        for row in answer.find_elements(By.CSS_SELECTOR, "tbody tr")
    ]
    assert methods == ["ground", "line", "point"]
    verdicts = [p.text for p in browser.find_elements(By.CSS_SELECTOR, "p.verdict")]
    assert any(v.startswith("point (method 1)") for v in verdicts), verdicts
    links = [a.get_attribute("href") for a in browser.find_elements(By.CSS_SELECTOR, "nav a")]
    assert all(browser.find_elements(By.ID, link.rsplit("#", 1)[1]) for link in links)


def test_screenshot_of_the_top_of_the_report_is_the_window_and_has_content(
    report: Path, browser: Any
) -> None:
    """What a reader sees first: a screenshot as wide as the window (no horizontal
    scrollbar steals a row of it), with text in it, not a blank page."""
    browser.get(report.as_uri())
    shot = np.asarray(Image.open(io.BytesIO(browser.get_screenshot_as_png())).convert("L"))
    inner_width = browser.execute_script("return window.innerWidth")
    assert shot.shape[1] == inner_width
    dark = shot < 128
    assert dark.mean() > 0.005  # text and table rules
    columns_with_ink = np.flatnonzero(dark.any(axis=0))
    assert columns_with_ink.max() < inner_width - 10  # nothing runs to the right edge
