"""A real headless Chromium for the tests (Debian's chromium and chromium-driver, driven by
Selenium). Without it a test module is skipped, except in CI, where it must run
(``.ci/run`` installs it)."""

from __future__ import annotations

import contextlib
import os
import shutil
from collections.abc import Iterator
from pathlib import Path
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
def headless_chromium(width: int, height: int, *, fonts: Path | None = None) -> Iterator[Any]:
    """A headless Chromium window of ``width`` x ``height`` (a Selenium driver); with
    ``fonts``, a fontconfig file (:func:`other_fonts`), the fonts it names instead of the
    machine's."""
    from selenium import webdriver
    from selenium.webdriver.chrome.service import Service

    chromium, chromedriver = require_chromium()
    options = webdriver.ChromeOptions()
    options.binary_location = chromium
    for flag in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu"):
        options.add_argument(flag)
    options.add_argument(f"--window-size={width},{height}")
    env = dict(os.environ, FONTCONFIG_FILE=str(fonts)) if fonts else None
    service = Service(executable_path=chromedriver, env=env)
    driver = webdriver.Chrome(service=service, options=options)
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


#: Fonts no Debian machine maps ``sans-serif`` or ``monospace`` to unless it has nothing
#: else: matplotlib's STIX (a Times-like serif) and Computer Modern typewriter, which the
#: venv carries on every machine.
OTHER_FONTS = ("STIXGeneral.ttf", "STIXGeneralBol.ttf", "STIXGeneralItalic.ttf", "cmtt10.ttf")


def other_fonts(folder: Path) -> Path:
    """A fontconfig file in ``folder`` that shows Chromium :data:`OTHER_FONTS` alone, with
    the machine's rendering settings (hinting, anti-aliasing): another machine's fonts."""
    import matplotlib

    source = Path(matplotlib.__file__).parent / "mpl-data" / "fonts" / "ttf"
    fonts = folder / "fonts"
    fonts.mkdir(parents=True, exist_ok=True)
    for name in OTHER_FONTS:
        shutil.copyfile(source / name, fonts / name)
    config = folder / "fonts.conf"
    config.write_text(
        '<?xml version="1.0"?>\n<!DOCTYPE fontconfig SYSTEM "urn:fontconfig:fonts.dtd">\n'
        f"<fontconfig><dir>{fonts}</dir><cachedir>{folder / 'cache'}</cachedir>"
        '<include ignore_missing="yes">/etc/fonts/conf.d</include></fontconfig>\n'
    )
    return config


#: Marks the elements whose fonts :func:`fonts_drawn` asks for: one per kind of text
#: (element, font, weight, style), and one per character beyond ASCII and kind.
_PROBE = """
const seen = new Set();
let n = 0;
for (const e of document.querySelectorAll('body *')) {
  if (['SCRIPT', 'STYLE'].includes(e.tagName) || !e.getClientRects().length) continue;
  const own = [...e.childNodes].filter(c => c.nodeType === 3).map(c => c.data).join('').trim();
  if (!own) continue;
  const s = getComputedStyle(e);
  const kind = [e.tagName, s.fontFamily, s.fontWeight, s.fontStyle].join('|');
  const keys = [kind, ...[...own].filter(c => c > '~').map(c => kind + c)];
  if (keys.some(k => !seen.has(k))) {
    keys.forEach(k => seen.add(k));
    e.setAttribute('data-font-probe', '');
    n += 1;
  }
}
return n;
"""


def fonts_drawn(driver: Any) -> dict[tuple[str, bool], list[str]]:
    """The fonts the page's text is drawn in, as Chromium says it drew it (DevTools'
    ``CSS.getPlatformFontsForNode``): (family, whether it is one the page carries) ->
    the elements drawn in it (their tag and start of text); every kind of text is asked
    (element, font, weight, style) and every character beyond ASCII."""
    assert driver.execute_script(_PROBE)
    driver.execute_cdp_cmd("DOM.enable", {})
    driver.execute_cdp_cmd("CSS.enable", {})
    root = driver.execute_cdp_cmd("DOM.getDocument", {"depth": 0})["root"]["nodeId"]
    found = driver.execute_cdp_cmd(
        "DOM.querySelectorAll", {"nodeId": root, "selector": "[data-font-probe]"}
    )
    drawn: dict[tuple[str, bool], list[str]] = {}
    for node in found["nodeIds"]:
        fonts = driver.execute_cdp_cmd("CSS.getPlatformFontsForNode", {"nodeId": node})
        html = driver.execute_cdp_cmd("DOM.getOuterHTML", {"nodeId": node})["outerHTML"]
        for font in fonts["fonts"]:
            key = (font["familyName"], bool(font.get("isCustomFont")))
            drawn.setdefault(key, []).append(html[:80])
    return drawn
