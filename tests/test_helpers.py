"""The tests' helpers wait for what another process writes (tests/helpers.py, issue 53): a
scheduler file seen half-written is read again until it is whole; a file never completed,
or a process that ends or stays silent, is given up within its bound, saying what was
waited for and what was found."""

from __future__ import annotations

import json
import subprocess
import sys
import threading
import time
from pathlib import Path

import pytest

from tests.helpers import read_line_when_printed, read_when_complete, scheduler_address

WHOLE = json.dumps({"type": "Scheduler", "id": "Scheduler-1", "address": "tcp://127.0.0.1:4242"})


def _complete_later(path: Path, text: str, after_s: float) -> threading.Thread:
    def write() -> None:
        time.sleep(after_s)
        path.write_text(text)

    thread = threading.Thread(target=write)
    thread.start()
    return thread


@pytest.mark.parametrize("seen", ["", WHOLE[:30]], ids=["empty", "half-written"])
def test_a_half_written_scheduler_file_is_waited_for(tmp_path: Path, seen: str) -> None:
    """What the dask scheduler leaves for a moment (issue 53's JSONDecodeError)."""
    file = tmp_path / "scheduler.json"
    file.write_text(seen)
    writer = _complete_later(file, WHOLE, 0.3)
    started = time.monotonic()
    assert scheduler_address(file, timeout_s=10) == "tcp://127.0.0.1:4242"
    assert time.monotonic() - started >= 0.25  # it waited for the rest
    writer.join()


def test_a_file_never_completed_is_given_up_saying_what_was_waited_for(tmp_path: Path) -> None:
    file = tmp_path / "scheduler.json"
    with pytest.raises(AssertionError) as missing:
        scheduler_address(file, timeout_s=0.2)
    assert "waited 0.2 s for the Dask scheduler's file" in str(missing.value)
    assert "it does not exist" in str(missing.value)
    file.write_text(WHOLE[:30])
    with pytest.raises(AssertionError, match="holds 30 characters that do not parse"):
        scheduler_address(file, timeout_s=0.2)
    # A writer that exits is not waited for to the end of the bound.
    gone = subprocess.Popen([sys.executable, "-c", "raise SystemExit(3)"])
    gone.wait()
    started = time.monotonic()
    with pytest.raises(AssertionError, match=r"its writer exited \(3\) for the pid file"):
        read_when_complete(tmp_path / "pid", int, "the pid file", timeout_s=30, writer=gone)
    assert time.monotonic() - started < 5


def test_a_line_is_waited_for_within_its_bound(tmp_path: Path) -> None:
    def start(code: str) -> subprocess.Popen[str]:
        command = [sys.executable, "-u", "-c", code]
        return subprocess.Popen(command, stdout=subprocess.PIPE, text=True)

    printing = start("import time; print('warming up'); time.sleep(0.2); print('at http://x/')")
    line, before = read_line_when_printed(printing, "http://", "the address", timeout_s=30)
    assert (line, before) == ("at http://x/\n", "warming up\n")
    printing.wait(timeout=10)
    silent = start("import time; print('starting'); time.sleep(60)")
    with pytest.raises(AssertionError, match=r"waited 0.5 s for the address .*'starting\\n'"):
        read_line_when_printed(silent, "http://", "the address", timeout_s=0.5)
    assert silent.wait(timeout=10) != 0  # killed, not left running
    ended = start("print('no address')")
    with pytest.raises(AssertionError, match=r"the process ended \(0\) for the address"):
        read_line_when_printed(ended, "http://", "the address", timeout_s=30)
