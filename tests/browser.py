"""A real headless Chromium for the tests (Debian's chromium and chromium-driver, driven by
Selenium). Without it a test module is skipped, except in CI, where it must run
(``.ci/run`` installs it)."""

from __future__ import annotations

import contextlib
import os
import shutil
from collections.abc import Iterator
from typing import Any

import pytest


def require_chromium() -> tuple[str, str]:
    """The browser and its driver; skips the calling module (fails in CI) without them."""
    chromium = shutil.which("chromium") or shutil.which("chromium-browser")
    driver = shutil.which("chromedriver")
    if not (chromium and driver):
        if os.environ.get("CI"):
            pytest.fail("CI must have chromium and chromium-driver (.ci/run installs them)")
        pytest.skip("chromium and chromium-driver are not installed", allow_module_level=True)
    return chromium, driver


@contextlib.contextmanager
def headless_chromium(width: int, height: int) -> Iterator[Any]:
    """A headless Chromium window of ``width`` x ``height`` (a Selenium driver)."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    chromium, chromedriver = require_chromium()
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for flag in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu"):
        options.add_argument(flag)
    options.add_argument(f"--window-size={width},{height}")
    driver = webdriver.Chrome(service=Service(executable_path=chromedriver), options=options)
    try:
        yield driver
    finally:
        driver.quit()


def emulate_phone(driver: Any, width: int = 390, height: int = 844) -> None:
    """Make the page a phone's: a ``width`` x ``height`` viewport laid out as a phone does
    (headless Chromium's window is at least 500 px wide; a page wider than the phone's
    screen widens the layout viewport, as the phone's browser does)."""
    driver.execute_cdp_cmd(
        "Emulation.setDeviceMetricsOverride",
        {"width": width, "height": height, "deviceScaleFactor": 1, "mobile": True},
    )
