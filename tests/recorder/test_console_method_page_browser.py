"""The page shows what the method's spec says (:class:`twopose.methods.specs.MethodPage`), in a
real headless Chromium: the board's words changed in its spec are the words the page shows,
so nothing on the page is chosen by the method's name."""

from __future__ import annotations

import dataclasses
from pathlib import Path
from types import MappingProxyType
from typing import Any

import pytest

from tests.browser import headless_chromium, require_chromium
from twopose.methods.specs import METHOD_SPECS, Method

require_chromium()

from selenium.webdriver.common.by import By  # noqa: E402
from selenium.webdriver.support.ui import WebDriverWait  # noqa: E402

from tests.recorder.test_console_layout import _serving  # noqa: E402

# Slow (a real browser): make test-all and CI run it.
pytestmark = pytest.mark.slow


def _text(browser: Any, testid: str) -> str:
    script = "const e = document.querySelector(arguments[0]); return e ? e.innerText : ''"
    return str(browser.execute_script(script, f"[data-testid={testid}]"))


def test_the_page_shows_the_board_spec_s_words(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    import twopose.methods.specs
    from recorder.console.state import ConsoleSession
    from twopose.methods.targets import BoardPlacement
    from twopose.methods.topview import board_top_view
    from twopose.values.units import Units

    board = METHOD_SPECS[Method.BOARD]
    page = dataclasses.replace(
        board.page,
        camera_aside="ASIDE from the spec",
        objects_header="HEADER",
        sought="the SOUGHT thing",
        topview_title="TITLE from the spec",
        legend_cameras="CAMERAS from the spec",
        legend_segments=(("corners", "#", "CORNERS from the spec"),),
    )
    specs = dict(METHOD_SPECS) | {Method.BOARD: dataclasses.replace(board, page=page)}
    monkeypatch.setattr(twopose.methods.specs, "METHOD_SPECS", MappingProxyType(specs))

    placement = BoardPlacement(inner_corners=(9, 6), square=0.75, first_corner=(-3.0, 8.125, 24.0))
    view = board_top_view(placement, [(0.0, 0.0, 0.0), (2.0, 0.0, 0.0)]).to_json()
    frame = {"frame": 1, "found": False, "is_board": True, "reason": "no board"}
    with _serving(ConsoleSession(tmp_path / "board.mcap")) as (url, session):
        session.update(
            phase="recording", method=Method.BOARD, units=Units.IN, setup_fields=[],
            waiting="decision", trial=1, pose=3, n_poses=3, shortfall="none",
            frames=[frame], topview=view, message="trial 1 pose 3",
        )  # fmt: skip
        with headless_chromium(1366, 768) as browser:
            browser.get(url)
            title = browser.find_element(By.ID, "topview-title")
            WebDriverWait(browser, 30).until(
                lambda _: title.text == "TITLE from the spec", message="the state drawn"
            )
            assert browser.find_element(By.ID, "camera-aside").text == "ASIDE from the spec"
            heads = browser.find_elements(By.CSS_SELECTOR, "#frames-table th")
            assert [h.text for h in heads if h.is_displayed()] == ["#", "HEADER"]
            assert _text(browser, "shortfall").startswith("the SOUGHT thing was not found")
            legend = _text(browser, "topview-legend")
            assert "CAMERAS from the spec" in legend
            assert "CORNERS from the spec" in legend
            assert browser.find_element(By.ID, "rig-section").is_displayed()
            assert not browser.find_element(By.ID, "trials-section").is_displayed()


def test_a_new_segment_kind_draws_in_its_declared_style(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    """A segment kind declared outside the page (a registered method's, say) is drawn in the
    style it carries, and its legend mark in its colour: the page's script names no kind."""
    import twopose.methods.specs
    from recorder.console.state import ConsoleSession
    from twopose.methods.topview import SegmentKind, TopView
    from twopose.values.units import Units

    kind = SegmentKind("wall_trace", colour="#00ff00", width=9.0)
    board = METHOD_SPECS[Method.BOARD]
    page = dataclasses.replace(
        board.page, legend_segments=((kind, "=", "WALL TRACE from the spec"),)
    )
    specs = dict(METHOD_SPECS) | {Method.BOARD: dataclasses.replace(board, page=page)}
    monkeypatch.setattr(twopose.methods.specs, "METHOD_SPECS", MappingProxyType(specs))
    view = TopView(
        trial=1, method=Method.BOARD, cameras=((0.0, 0.0), (4.0, 0.0)),
        segments=((kind, (0.0, 2.0), (4.0, 8.0)),), estimate=None, truth=None,
    ).to_json()  # fmt: skip
    with _serving(ConsoleSession(tmp_path / "board.mcap")) as (url, session):
        session.update(
            phase="recording", method=Method.BOARD, units=Units.IN, setup_fields=[],
            waiting="decision", trial=1, pose=2, n_poses=2, shortfall="none",
            frames=[], topview=view, message="trial 1 pose 2",
        )  # fmt: skip
        with headless_chromium(1366, 768) as browser:
            browser.get(url)
            WebDriverWait(browser, 30).until(
                lambda _: "WALL TRACE" in _text(browser, "topview-legend"), message="drawn"
            )
            mark = browser.find_element(By.CSS_SELECTOR, "#topview-legend .mark.segment")
            assert mark.value_of_css_property("color") == "rgba(0, 255, 0, 1)"
            green = browser.execute_script(
                "const c = document.getElementById('topview');"
                "const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
                "let n = 0; for (let i = 0; i < d.length; i += 4)"
                " if (d[i] < 40 && d[i + 1] > 215 && d[i + 2] < 40) n++; return n;"
            )
            assert green > 200  # the 9 px wide green segment, not a default 2 px grey one
