"""A pair's stream trial in the console, in a real headless Chromium at 1366x768: the
buttons on exactly when offered (start trial between trials; touch and end trial while it
streams), a touch typed and clicked, the point listed and recorded as the button's, the
one camera's pose form and decisions out of sight. (The files play from the server's
start, before the page is loaded: the touch is not timed to the dot's stay here; the
terminal's test times its key, tests/recorder/test_stream_trials.py.)"""

from __future__ import annotations

import time
from pathlib import Path

import pytest

from tests.browser import headless_chromium, require_chromium
from tests.conftest import built_once
from tests.helpers import RECORD, read_line_when_printed
from tests.recorder.moving_pair import MovingPair, moving_pair, write_moving_pair
from twopose.format.reader import SessionReader
from twopose.format.streams import read_pair_session

require_chromium()


def _write(folder: Path) -> None:
    write_moving_pair(folder)


@pytest.fixture(scope="module")
def moving(tmp_path_factory: pytest.TempPathFactory) -> MovingPair:
    return moving_pair(built_once(tmp_path_factory, "moving-pair", _write))


def _on(driver: object, element_id: str) -> bool:
    element = driver.find_element("id", element_id)  # type: ignore[attr-defined]
    return bool(element.is_displayed() and element.is_enabled())


def _wait(what: object, timeout_s: float = 10.0) -> None:
    deadline = time.monotonic() + timeout_s
    while not what():  # type: ignore[operator]
        assert time.monotonic() < deadline, "never happened"
        time.sleep(0.05)


def test_the_page_starts_touches_and_ends_a_stream_trial(
    moving: MovingPair, tmp_path: Path
) -> None:
    import subprocess

    out = tmp_path / "browser.mcap"
    process = subprocess.Popen(
        [str(RECORD), "new", str(out), "--pair", str(moving.pair_file), "--source",
         moving.source, "--ui", "--method", "point", "--units", "in", "--operator", "Ada"],
        stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True,
    )  # fmt: skip
    try:
        line, _ = read_line_when_printed(process, "http://", "the console's address")
        with headless_chromium(1366, 768) as driver:
            driver.get(line.split()[2])
            _wait(lambda: _on(driver, "stream-start"))
            assert not _on(driver, "stream-touch")
            assert not _on(driver, "stream-end")
            assert not driver.find_element("id", "pose-form").is_displayed()
            # before the first trial the pointing panel stands, saying no trial streams
            # (the column stood empty; the header said "no pair running": r7 K5)
            _wait(lambda: "no trial streams" in driver.find_element(
                "id", "pointing-conditioning").text)  # fmt: skip
            assert driver.find_element("id", "pointing-conditioning").is_displayed()
            assert "view shows once a trial" in driver.find_element("id", "live-note").text
            # nothing is drawn on a pair's preview, and the aside says so (r7 K5)
            aside = driver.find_element("id", "camera-aside").text
            assert aside == "camera 1's frames as recorded"
            assert not driver.find_element("id", "accept").is_displayed()
            driver.find_element("id", "stream-start").click()
            _wait(lambda: _on(driver, "stream-touch"))
            assert not _on(driver, "stream-start")
            # a mistyped touch is refused in words next to the button, and they stay
            # (the next state's render hid them at once: a new user's r7 K4)
            for axis, value in zip("xyz", ("0,75", "0.5", "11"), strict=True):
                driver.find_element("id", f"stream-{axis}").send_keys(value)
            driver.find_element("id", "stream-touch").click()
            refusal = driver.find_element("id", "stream-refusal")
            _wait(lambda: refusal.is_displayed() and "0,75" in refusal.text)
            time.sleep(0.5)  # a few polls of the state (the files run on: keep it short)
            assert refusal.is_displayed()
            assert "0,75" in refusal.text
            driver.find_element("id", "stream-x").clear()
            driver.find_element("id", "stream-x").send_keys("0.75")
            # behind camera 1 (a sign typed wrong): said once, next to the touch button
            driver.find_element("id", "stream-z").clear()
            driver.find_element("id", "stream-z").send_keys("-11")
            driver.find_element("id", "stream-touch").click()
            _wait(lambda: "behind camera 1" in refusal.text)
            assert not driver.find_element("id", "refusal").is_displayed()
            driver.find_element("id", "stream-z").clear()
            driver.find_element("id", "stream-z").send_keys("11")
            driver.find_element("id", "stream-touch").click()
            _wait(lambda: "touch 1 at (0.75, 0.5, 11) by button" in driver.find_element(
                "id", "stream-touches").text)  # fmt: skip
            driver.save_screenshot(str(tmp_path / "stream-console.png"))
            driver.find_element("id", "stream-end").click()
            _wait(lambda: _on(driver, "stream-start"))
            assert "trial 1:" in driver.find_element("id", "stream-ended").text
    finally:
        process.terminate()
        process.wait(timeout=30)
    with SessionReader(out) as reader:
        (trial,) = read_pair_session(reader).trials
    (touch,) = trial.touches
    assert touch.how == "button"
    assert touch.point == (0.75, 0.5, 11.0)
    # files are replayed at the machine's pace, stamped on their own clock from when they
    # opened: the button is the frame camera 1 last recorded, the one on the page (a new
    # user's r7 K6: stamped as it came, a touch landed seconds past the frames it meant)
    assert touch.time_ns in set(trial.camera1.capture_ns.tolist())
