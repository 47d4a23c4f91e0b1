"""The console draws its screen in the fonts it serves (issue 53): its style names them and
its server serves each one (in-process), and in a real Chromium on a machine whose fonts
are others every kind of text on the screen is drawn in them."""

from __future__ import annotations

import re
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest
from selenium.webdriver.common.by import By
from selenium.webdriver.support.ui import WebDriverWait
from starlette.testclient import TestClient

from recorder.console.guard import SECURITY_HEADERS
from recorder.console.server import ConsoleOptions, console_app
from recorder.console.state import ConsoleSession
from tests.browser import fonts_drawn, headless_chromium, other_fonts
from tests.helpers import start_console
from twopose.display import fonts as webfonts

ORIGIN = "http://127.0.0.1:8765"


@pytest.fixture
def client(tmp_path: Path) -> Iterator[TestClient]:
    given: dict[str, Any] = {"method": None, "ground_truth": [], "intrinsics_sigma": {}}
    session = ConsoleSession(tmp_path / "s.mcap", dict(given, size=(320, 240)))
    options = ConsoleOptions(source="synthetic", given=given, frames=2, size=(320, 240))
    with TestClient(console_app(session, options), base_url=ORIGIN) as client:
        assert client.get("/").status_code == 200  # the page sets the session's cookie
        yield client


def test_the_style_names_the_fonts_the_server_serves(client: TestClient) -> None:
    css = client.get("/style.css").text
    faces = re.findall(r"@font-face\s*\{([^}]*)\}", css)
    named = {
        (re.search(r'font-family:\s*"([^"]+)"', f).group(1),  # type: ignore[union-attr]
         int(re.search(r"font-weight:\s*(\d+)", f).group(1)),  # type: ignore[union-attr]
         re.search(r'url\("/fonts/([^"]+)"\)', f).group(1))  # type: ignore[union-attr]
        for f in faces
    }  # fmt: skip
    assert named == {(f.family, f.weight, f.file) for f in webfonts.FONTS}
    # Every font the style names is one of them, the machine's generic family after it.
    declared = re.findall(r"(?<![-\w])font(?:-family)?\s*:\s*([^;}]*)", css)
    assert len(declared) >= 5, declared
    for value in declared:
        if value.strip() == "inherit":
            continue
        ours = re.search(r'"twopose (Sans|Mono)"', value)
        assert ours is not None, value
        generic = re.search(r"\b(sans-serif|serif|monospace|system-ui)\b", value)
        assert generic is None or ours.start() < generic.start(), value
    for font in webfonts.FONTS:
        answer = client.get(f"/fonts/{font.file}")
        assert answer.status_code == 200
        assert answer.headers["content-type"] == "font/woff"
        assert answer.content == webfonts.font_bytes(font.file)
        assert (
            answer.headers["Content-Security-Policy"] == SECURITY_HEADERS["Content-Security-Policy"]
        )
    assert client.get("/fonts/LICENSE-DejaVu.txt").status_code == 404
    assert client.get("/fonts/../style.css").status_code in (200, 404)  # no folder served


@pytest.mark.slow
def test_the_screen_is_drawn_in_its_fonts_on_a_machine_with_other_fonts(tmp_path: Path) -> None:
    process, url, _ = start_console(tmp_path / "s.mcap")
    try:
        with headless_chromium(1366, 768, fonts=other_fonts(tmp_path / "fonts")) as browser:
            browser.get(url)
            WebDriverWait(browser, 30).until(
                lambda b: (
                    b.find_elements(By.ID, "f-method")
                    and b.execute_script("return document.fonts.status") == "loaded"
                ),
                "the setup form, its fonts loaded",
            )
            drawn = fonts_drawn(browser)
    finally:
        process.terminate()
        process.wait(timeout=30)
    not_ours = {font: where[:3] for font, where in drawn.items() if not font[1]}
    assert not not_ours, not_ours
    assert set(drawn) == {("DejaVu Sans", True), ("DejaVu Sans Mono", True)}, drawn.keys()
