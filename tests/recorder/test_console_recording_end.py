"""How a console recording thread ends, one-camera and pair alike (recorder.console.driver):
its summary printed once, and a failure said on the page in words, never a traceback."""

from __future__ import annotations

from pathlib import Path

import pytest

from recorder.console.driver import said_ended, said_failed
from recorder.console.state import ConsoleSession
from twopose.errors import SourceError


def test_a_failure_is_said_on_the_page_in_its_own_words_or_named_by_its_type(
    tmp_path: Path,
) -> None:
    session = ConsoleSession(tmp_path / "s.mcap")
    said_failed(session, SourceError("camera 2 stopped: no frame for 1 s"))
    assert (session.phase, session.waiting) == ("failed", "")
    assert session.message == "camera 2 stopped: no frame for 1 s"
    said_failed(session, ZeroDivisionError("division by zero"))
    assert session.message == "ZeroDivisionError: division by zero"


@pytest.mark.parametrize("stopped", [False, True])
def test_the_summary_is_printed_once_with_how_to_stop_unless_stopping(
    stopped: bool, capsys: pytest.CaptureFixture[str]
) -> None:
    said_ended("wrote s.mcap: 2 trials", stopped=stopped)
    out = capsys.readouterr().out
    assert out.count("wrote s.mcap: 2 trials") == 1
    assert ("Ctrl-C stops the console" in out) is not stopped
