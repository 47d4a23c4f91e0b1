"""A value given is shown back as given in the page (issue 55, item 4), in a real headless
Chromium at 1366x768: the setup line of a console whose setup the command line gave says
``--focal 525.000`` as 525.000 and the typed truth 4.8514, 9.6250, 21.2725 unrounded
(it read f 525 px and (4.851, 9.625, 21.273)). The screenshot goes to the test's folder."""

from __future__ import annotations

import signal
from pathlib import Path

import pytest

from tests.browser import headless_chromium, require_chromium
from tests.helpers import start_console
from tests.recorder.test_console_browser import Page

require_chromium()

pytestmark = pytest.mark.slow


def test_the_setup_line_shows_each_value_as_given(tmp_path: Path) -> None:
    out = tmp_path / "s.mcap"
    process, url, _ = start_console(
        out, "--method", "ground", "--units", "in", "--focal", "525.000", "--principal",
        "320,240", "--ground-height", "9.6250", "--ground-truth", "4.8514,9.6250,21.2725",
        "--operator", "Ada", "--target-precision", "2.50e-1",
    )  # fmt: skip
    try:
        with headless_chromium(1366, 768) as browser:
            browser.get(url)
            page = Page(browser)
            page.click("setup-submit")  # the form holds what the command line gave
            page.wait(lambda: "method ground" in page.text("session-setup"), "the setup line")
            shown = page.text("session-setup")
            browser.save_screenshot(str(tmp_path / "setup-line.png"))
    finally:
        process.send_signal(signal.SIGINT)
        process.wait(timeout=30)
    assert "f 525.000 px, principal point (320, 240) px" in shown
    assert "ground truth (4.8514, 9.6250, 21.2725) in" in shown
    assert "ground height 9.6250 in" in shown
    assert "within 2.50e-1 in" in shown
