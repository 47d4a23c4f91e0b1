"""report.html's charts in a real headless Chromium (:mod:`analysis.report.charts`, drawn by the
Vega-Lite scripts the package carries): every chart has data and names its units; hovering
a point names its session, trial and error; clicking a trial picks it out in every chart of
its session; the page asks nothing of the network and draws its charts with the network
off. Skipped without Chromium, except in CI (``tests.browser``)."""

from __future__ import annotations

import re
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from tests.browser import headless_chromium, require_chromium

require_chromium()

# A real browser over make run's report (built once, shared with test_report_browser.py):
# a few seconds, so make test-all and CI run it, not the quick loop.
pytestmark = pytest.mark.slow

from selenium.webdriver.common.action_chains import ActionChains  # noqa: E402
from selenium.webdriver.common.by import By  # noqa: E402

# Each chart cell of a view: its marks' item counts, its axes' titles, and the
# (trial, opacity) of every item drawn for a trial.
_CELLS = r"""
const view = window.twoposeViews[arguments[0]];
function marks(item, out) {
  (item.items || []).forEach(function (m) {
    if (m.marktype === 'group') (m.items || []).forEach(function (g) { marks(g, out); });
    else if (m.role === 'mark') out.push(m);
  });
  return out;
}
function titles(item, out) {
  (item.items || []).forEach(function (m) {
    if (m.role === 'axis-title') m.items.forEach(function (t) { out.push(t.text); });
    (m.items || []).forEach(function (i) { titles(i, out); });
  });
  return out;
}
const cells = [];
view.scenegraph().root.items[0].items.forEach(function (m) {
  if (m.marktype === 'group' && /concat_\d+_group/.test(m.name))
    m.items.forEach(function (g) { cells.push(g); });
});
return cells.map(function (c) {
  const ms = marks(c, []);
  const trials = [];
  ms.forEach(function (m) { m.items.forEach(function (i) {
    if (i.datum && i.datum.trial !== undefined && i.opacity !== undefined)
      trials.push([i.datum.trial, i.opacity]);
  }); });
  return {items: ms.reduce(function (n, m) { return n + m.items.length; }, 0),
          titles: titles(c, []), trials: trials};
});
"""


@pytest.fixture(scope="module")
def report(bundled_run: Path) -> Path:
    """The report of ``make run``: the bundled sample sessions."""
    return bundled_run / "report.html"


@pytest.fixture(scope="module")
def browser(report: Path) -> Iterator[Any]:
    with headless_chromium(1280, 900) as driver:
        driver.get(report.as_uri())
        _wait_for_charts(driver)
        yield driver


def _wait_for_charts(driver: Any) -> list[str]:
    expected = driver.execute_script("return document.querySelectorAll('div.chart').length")
    for _ in range(100):
        drawn: list[str] = driver.execute_script("return Object.keys(window.twoposeViews || {})")
        if len(drawn) == expected:
            return drawn
        time.sleep(0.1)
    raise AssertionError(f"{len(drawn)} of {expected} charts drawn")


def test_every_chart_has_data_and_names_its_units(browser: Any) -> None:
    names = _wait_for_charts(browser)
    assert {"overview", "sensitivity"} <= set(names)
    assert sum(n.startswith("session_") for n in names) == 7  # one per bundled session
    for name in names:
        cells = browser.execute_script(_CELLS, name)
        assert cells, name
        for cell in cells:
            assert cell["items"] > 0, (name, cell)
            # two axes named (a chart of a panel per session set repeats its y axis)
            assert len(set(cell["titles"])) == 2, (name, cell["titles"])
            for title in cell["titles"]:  # a unit, or a count, or the sessions' names
                counted = title.startswith("number of") or title == "session"
                assert re.search(r"\(.+\)", title) or counted, (name, title)


def _point(browser: Any, chart: str) -> Any:
    return browser.find_element(
        By.CSS_SELECTOR, f"div[data-chart='{chart}'] g.scatter_points_marks path"
    )


def test_hovering_a_point_names_its_session_trial_and_error_with_units(browser: Any) -> None:
    point = _point(browser, "session_05")
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", point)
    ActionChains(browser).move_to_element(point).perform()
    tooltip = browser.find_element(By.ID, "vg-tooltip-element")
    for _ in range(20):
        if tooltip.is_displayed() and tooltip.text:
            break
        time.sleep(0.1)
    text = tooltip.text
    assert "thesis_method1_point" in text, text
    assert re.search(r"trial\s+\d+", text), text
    assert re.search(r"error \(in\)\s+\d+\.\d{3}", text), text


def test_clicking_a_trial_picks_it_out_in_every_chart_of_its_session(browser: Any) -> None:
    point = _point(browser, "session_05")
    browser.execute_script("arguments[0].scrollIntoView({block: 'center'})", point)
    ActionChains(browser).move_to_element(point).click().perform()
    store = "return window.twoposeViews['session_05'].data('pick_store').length"
    for _ in range(30):
        if browser.execute_script(store):
            break
        time.sleep(0.1)
    browser.execute_script("window.twoposeViews['session_05'].run()")
    cells = browser.execute_script(_CELLS, "session_05")
    picked = {t for cell in cells for t, o in cell["trials"] if o >= 0.6}
    assert len(picked) == 1, picked  # one trial stands out ...
    for cell in cells:  # ... in every chart of the session, the others faded
        assert cell["trials"], cell
        for trial, opacity in cell["trials"]:
            assert (opacity >= 0.6) == (trial in picked), (trial, opacity)
    # Another session's charts are untouched.
    other = browser.execute_script(_CELLS, "session_06")
    assert all(o >= 0.6 for cell in other for _, o in cell["trials"])


def test_the_page_asks_nothing_of_the_network_and_draws_offline(report: Path) -> None:
    with headless_chromium(1280, 900) as driver:
        driver.execute_cdp_cmd("Network.enable", {})
        driver.execute_cdp_cmd(
            "Network.emulateNetworkConditions",
            {"offline": True, "latency": 0, "downloadThroughput": 0, "uploadThroughput": 0},
        )
        driver.get(report.as_uri())
        names = _wait_for_charts(driver)
        assert len(names) >= 9
        links = driver.execute_script(
            "return Array.from(document.querySelectorAll('[src],[href]'))"
            ".map(e => e.getAttribute('src') || e.getAttribute('href'))"
        )
        assert all(link.startswith("#") or ":" not in link for link in links), links
        resources = driver.execute_script(
            "return performance.getEntriesByType('resource').map(e => e.name)"
        )
        assert all(r.startswith(("file:", "data:")) for r in resources), resources
