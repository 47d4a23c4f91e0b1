"""report.html in a real headless Chromium (Debian's ``chromium`` and ``chromium-driver``,
driven by Selenium): at a 1280 px window and at a 390 px phone nothing overflows the page
(a wide table or chart scrolls in its own box, with a visible cue), every chart is drawn,
the answer comes first (the thesis' sessions first, in words and units) and the charts'
largest errors are the answer's (the charts' own behaviour: test_report_charts_browser.py).
``.ci/run`` installs the browser; elsewhere the test is skipped when it is missing (and
fails in CI, where it must run)."""

from __future__ import annotations

import io
import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image

from tests.browser import fonts_drawn, headless_chromium, other_fonts, require_chromium
from tests.doc_images import doc_image

require_chromium()

from selenium.webdriver.common.by import By  # noqa: E402

WIDTH, HEIGHT = 1280, 900
PHONE = 390


@pytest.fixture(scope="module")
def report(bundled_run: Path) -> Path:
    """The report of ``make run``: the bundled sample sessions."""
    return bundled_run / "report.html"


@pytest.fixture(scope="module")
def browser() -> Iterator[Any]:
    with headless_chromium(WIDTH, HEIGHT) as driver:
        yield driver


def test_report_fits_a_1280_px_window_and_every_chart_is_drawn(report: Path, browser: Any) -> None:
    browser.get(report.as_uri())
    inner_width = browser.execute_script("return window.innerWidth")
    page_width = browser.execute_script(
        "return Math.max(document.documentElement.scrollWidth, document.body.scrollWidth)"
    )
    assert inner_width <= WIDTH
    assert page_width <= inner_width, f"the page is {page_width} px wide in {inner_width} px"

    charts = browser.find_elements(By.CSS_SELECTOR, "div.chart")
    assert len(charts) >= 9  # the overview, sensitivity and one per session
    for _ in range(100):  # drawn by the page's script, once loaded
        drawn = browser.execute_script("return Object.keys(window.twoposeViews).length")
        if drawn == len(charts):
            break
        time.sleep(0.1)
    assert drawn == len(charts)
    for chart in charts:
        assert chart.find_elements(By.TAG_NAME, "svg"), chart.get_attribute("data-chart")
    assert not browser.find_elements(By.TAG_NAME, "img")  # no picture: --figures writes them

    # Every wide table scrolls inside its own box, which stays inside the window.
    boxes = browser.find_elements(By.CSS_SELECTOR, "div.scroll")
    assert boxes
    assert all(box.rect["x"] + box.rect["width"] <= inner_width + 1 for box in boxes)


def test_report_answers_first(report: Path, browser: Any) -> None:
    browser.get(report.as_uri())
    headings = [h.text for h in browser.find_elements(By.CSS_SELECTOR, "h2")]
    assert headings[0] == "Answer per method"
    # The bundled sessions declare two sets: the thesis' experiments come first.
    sets = [h.get_attribute("id") for h in browser.find_elements(By.CSS_SELECTOR, "h3[id^=set-]")]
    assert sets == ["set-thesis", "set-stress"]
    answer = browser.find_element(By.CSS_SELECTOR, "#set-thesis + div table")
    header = _header(answer)
    assert {
        "method",
        "RMSE (in)",
        "median (in)",
        "largest (in)",
        "within 1 in",
        "bias x ± 95% (in)",
        "warned (left out)",
        "truth inside its 95% ellipsoid",
    } <= set(header), header
    rows = [
        [td.text for td in row.find_elements(By.TAG_NAME, "td")]
        for row in answer.find_elements(By.CSS_SELECTOR, "tbody tr")
    ]
    assert [r[0] for r in rows] == ["ground (method 2)", "line", "point (method 1)"]
    within = header.index("within 1 in")
    for row in rows:  # two decimals, shares in percent
        assert re.fullmatch(r"\d+\.\d\d", row[header.index("RMSE (in)")]), row
        assert re.fullmatch(r"\d+%", row[within]), row
    verdicts = [p.text for p in browser.find_elements(By.CSS_SELECTOR, "p.verdict")]
    assert verdicts[2].startswith("point (method 1): 15 of 15 trials within 1 in"), verdicts
    assert "reproduced" in verdicts[2]
    links = [a.get_attribute("href") for a in browser.find_elements(By.CSS_SELECTOR, "nav a")]
    assert all(browser.find_elements(By.ID, link.rsplit("#", 1)[1]) for link in links)


def test_a_phone_sees_the_answers_numbers_on_its_first_screen_whatever_failed(
    tmp_path: Path, browser: Any
) -> None:
    """Issue 47: with a failed input, at 390 px, the first answer table's rows and its
    verdict are within the first screen (how to read them comes after)."""
    from analysis.batch.runner import run

    folder = tmp_path / "sessions"
    folder.mkdir()
    line = Path(__file__).resolve().parents[2] / "sessions" / "thesis_line.mcap"
    (folder / "thesis_line.mcap").write_bytes(line.read_bytes())
    point = line.with_name("thesis_method1_point.mcap")  # another session, cut short
    (folder / "zz_corrupt.mcap").write_bytes(point.read_bytes()[:5000])
    result = run([folder], tmp_path / "out", scene=False)
    assert result.failed
    _emulate(browser, PHONE)
    browser.get((tmp_path / "out" / "report.html").as_uri())
    first_screen = browser.execute_script("return window.innerHeight")
    row = browser.find_element(By.CSS_SELECTOR, "#answer ~ div table tbody tr")
    verdict = browser.find_element(By.CSS_SELECTOR, "p.verdict")
    failed = browser.find_element(By.CSS_SELECTOR, "p.inputs-line")
    try:
        assert failed.rect["y"] < row.rect["y"]  # the count of the failed first, one line
        assert row.rect["y"] + row.rect["height"] <= first_screen, row.rect
        assert verdict.rect["y"] < first_screen, verdict.rect
    finally:
        _emulate(browser, None)


def _header(table: Any) -> list[str]:
    return [th.text.replace("\n", " ") for th in table.find_elements(By.CSS_SELECTOR, "thead th")]


_METHOD_LABEL = {"point": "point (method 1)", "ground": "ground (method 2)", "line": "line"}


def test_figures_largest_errors_are_the_answers(report: Path, browser: Any) -> None:
    """Each overview figure's caption names the largest error it draws per set and method:
    the answer table's "largest" (warned trials are left out of both)."""
    browser.get(report.as_uri())
    largest: dict[tuple[str, str], str] = {}
    for name in ("thesis", "stress"):
        table = browser.find_element(By.CSS_SELECTOR, f"#set-{name} + div table")
        header = _header(table)
        column = header.index("largest (in)")
        for row in table.find_elements(By.CSS_SELECTOR, "tbody tr"):
            cells = [td.text for td in row.find_elements(By.TAG_NAME, "td")]
            largest[(name, cells[0])] = cells[column]
    spans = browser.find_elements(By.CSS_SELECTOR, "#figures ~ figure span.largest")
    assert len(spans) == len(largest)  # the overview charts' caption
    for span in spans:
        method = _METHOD_LABEL[span.get_attribute("data-method")]
        assert span.text == largest[(span.get_attribute("data-set"), method)], method


@pytest.mark.parametrize("width", [WIDTH, PHONE])
def test_every_axis_names_its_unit_and_nothing_overflows_without_a_cue(
    report: Path, browser: Any, width: int
) -> None:
    _emulate(browser, width)
    browser.get(report.as_uri())
    inner_width = browser.execute_script("return window.innerWidth")
    assert inner_width == width
    page_width = browser.execute_script("return document.documentElement.scrollWidth")
    assert page_width <= inner_width, f"the page is {page_width} px wide in {inner_width} px"
    overflowing = 0
    for box in browser.find_elements(By.CSS_SELECTOR, "div.scroll"):
        wider = browser.execute_script(
            "return arguments[0].scrollWidth > arguments[0].clientWidth + 1", box
        )
        cue = browser.execute_script(
            "return getComputedStyle(arguments[0].parentElement, '::before').content", box
        )
        assert box.rect["x"] + box.rect["width"] <= inner_width + 1
        if wider:
            overflowing += 1
            assert "scroll sideways" in cue, box.get_attribute("innerHTML")[:200]
        else:
            assert cue in ("none", "normal", ""), cue
    if width == PHONE:
        assert overflowing  # the phone does scroll some tables, each with its cue
    # no chart's title or label cut short ("…"): a phone wraps the long titles onto lines
    for _ in range(100):
        drawn = browser.execute_script(
            "return Object.keys(window.twoposeViews || {}).length"
            " === document.querySelectorAll('div.chart').length"
        )
        if drawn:
            break
        time.sleep(0.1)
    cut = browser.execute_script(
        "return [...document.querySelectorAll('div.chart svg text')]"
        ".map(t => t.textContent).filter(t => t.includes('\u2026'))"
    )
    assert drawn
    assert cut == [], cut
    _emulate(browser, None)


def _emulate(browser: Any, width: int | None) -> None:
    """A viewport ``width`` px wide, as a phone below 600 px (``None``: the window's)."""
    if width is None:
        browser.execute_cdp_cmd("Emulation.clearDeviceMetricsOverride", {})
        return
    metrics = {"width": width, "height": HEIGHT, "deviceScaleFactor": 1, "mobile": width < 600}
    browser.execute_cdp_cmd("Emulation.setDeviceMetricsOverride", metrics)


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


def test_the_docs_show_the_reports_answer_and_a_figure_as_a_laptop_sees_them(
    report: Path,
) -> None:
    """docs/analysis.md and the home page show the report at 1366x768: its top (the
    answer) and the first session's charts, as this browser draws them."""
    with headless_chromium(1366, 768) as laptop:
        laptop.get(report.as_uri())
        _wait_for_charts(laptop)
        doc_image("report-answer.png", laptop.get_screenshot_as_png(), driver=laptop)
        figure = laptop.find_element(By.CSS_SELECTOR, "div.chart[data-chart^='session_'] svg")
        laptop.execute_script("arguments[0].scrollIntoView({block: 'center'})", figure)
        doc_image("report-figure.png", figure.screenshot_as_png, driver=laptop, element=figure)


@pytest.fixture(scope="module")
def forked_report(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The report of a lab's forked session (:mod:`tests.lab`'s drawn sessions): ``a``
    (5 trials) continued after trial 5 by ``a2`` (branch A, 1 trial) and ``a3`` (B, 2)."""
    from analysis.batch.runner import run
    from tests.lab import continue_session, record

    folder = tmp_path_factory.mktemp("forked")
    record(folder / "a.mcap", 5, measured=True)
    continue_session(folder / "a.mcap", folder / "a2.mcap", 1, measured=True)
    continue_session(folder / "a.mcap", folder / "a3.mcap", 2, measured=True)
    run([folder], folder / "out", scene=False)
    return folder / "out" / "report.html"


@pytest.mark.parametrize("width", [1366, PHONE])
def test_a_forked_sessions_tables_show_branch_and_ellipsoid_within_the_page(
    forked_report: Path, browser: Any, width: int
) -> None:
    """Issue 56: as a reader sees them at 1366 px and on a phone, a forked session's
    heading and trial table name the branch, its "truth inside its 95% ellipsoid" cells
    read yes/no (they read "-"), a 2-trial session's interval cell says why there is none,
    and the wider tables scroll in their boxes, the page never wider than the screen."""
    _emulate(browser, width)
    try:
        browser.get(forked_report.as_uri())
        inner = browser.execute_script("return window.innerWidth")
        assert browser.execute_script("return document.documentElement.scrollWidth") <= inner
        headings = [h.text for h in browser.find_elements(By.CSS_SELECTOR, "h3")]
        assert {"a.mcap [branch A]", "a3.mcap [branch B]"} <= set(headings)
        cells = browser.execute_script(
            "return [...document.querySelectorAll('table')].filter(t => {"
            " const h = [...t.querySelectorAll('th')].map(x => x.textContent);"
            " return h.includes('branch') && h.includes('status'); }).map(t => {"
            " const h = [...t.querySelectorAll('th')].map(x => x.textContent);"
            " const b = h.indexOf('branch'), w = h.indexOf('truth inside its 95% ellipsoid');"
            " return [...t.querySelectorAll('tbody tr')].map(r =>"
            " [r.children[b].textContent, r.children[w].textContent]); })"
        )
        assert [len(t) for t in cells] == [6, 2]  # a's 5 and a2's 1; a3's 2
        assert sorted({b for t in cells for b, _ in t}) == ["", "A", "B"]
        assert {w for t in cells for _, w in t} <= {"yes", "no"}
        assert "none (2 trials: an interval needs 5)" in browser.page_source
    finally:
        _emulate(browser, None)


def test_the_report_is_drawn_in_its_own_fonts_on_a_machine_with_other_fonts(
    report: Path, tmp_path: Path
) -> None:
    """Issue 53: on a machine whose fonts are others (matplotlib's STIX and Computer
    Modern alone: its sans-serif a serif), every kind of text and every character beyond
    ASCII, charts' included, is drawn in the fonts the report carries, and its top is the
    docs' picture, drawn with this machine's fonts."""
    with headless_chromium(1366, 768, fonts=other_fonts(tmp_path)) as other:
        other.get(report.as_uri())
        _wait_for_charts(other)
        doc_image("report-answer.png", other.get_screenshot_as_png(), driver=other)
        drawn = fonts_drawn(other)
    assert {family for family, _ in drawn} == {"DejaVu Sans", "DejaVu Sans Mono"}, drawn.keys()
    not_ours = {font: where[:3] for font, where in drawn.items() if not font[1]}
    assert not not_ours, not_ours
    assert any("<text" in e for e in drawn[("DejaVu Sans", True)])  # the charts' labels


def _wait_for_charts(browser: Any) -> None:
    """Until the page's fonts are loaded and its script drew every chart with them."""
    drawn = False
    for _ in range(100):
        drawn = browser.execute_script(
            "return document.fonts.status === 'loaded' && Object.keys(window.twoposeViews"
            " || {}).length === document.querySelectorAll('div.chart').length"
        )
        if drawn:
            break
        time.sleep(0.1)
    assert drawn, "the charts were not drawn in 10 s"
