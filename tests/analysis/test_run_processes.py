"""A run's processes end with it: ``run --jobs 2`` killed (kill -9), interrupted (Ctrl-C;
SIGTERM takes the same path, :func:`twopose.errors.watch_interrupts`) or writing into a
closed stdout leaves no process behind within seconds, and prints no traceback. A killed
run's spawned worker used to block for ever in a pipe, holding the run's stdout, so that
``run ... | tee log`` never returned.

Real processes: the command line as a user starts it, in its own process group.
"""

from __future__ import annotations

import contextlib
import os
import random
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import psutil
import pytest

from analysis.parent_watch import EXIT_PARENT_GONE
from tests.helpers import distinct_copies

REPO = Path(__file__).resolve().parents[2]
SAMPLES = REPO / "sessions"
#: How long a run's processes may outlive it: a worker sees its parent's end at once, or
#: once it has imported what it runs (its watch starts in the pool's initializer).
GONE_S = 5.0

pytestmark = pytest.mark.skipif(sys.platform != "linux", reason="process groups, /proc")


@pytest.fixture(scope="module")
def sessions(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """About 9 s of work for two processes: a run is still busy when it is killed.
    Distinct files: copies of one session would be counted once."""
    folder = tmp_path_factory.mktemp("sessions")
    distinct_copies(SAMPLES / "thesis_method2_ground.mcap", folder, 12)
    return folder


def _start(
    folder: Path, out: Path, stderr: Path, *, jobs: int = 2, stdout: int = subprocess.DEVNULL,
    extra: tuple[str, ...] = (),
) -> subprocess.Popen[bytes]:  # fmt: skip
    """``twopose-analyze run FOLDER --out OUT --jobs JOBS`` in a new process group; its
    stderr into a file (a leftover process holding a pipe would hang a reader)."""
    command = ["run", str(folder), "--out", str(out), "--jobs", str(jobs), *extra]
    with open(stderr, "wb") as err:
        return subprocess.Popen(
            [sys.executable, "-m", "analysis", *command],
            stdout=stdout,
            stderr=err,
            env={**os.environ, "PYTHONPATH": str(REPO)},
            start_new_session=True,
        )


def _running(group: int, known: list[psutil.Process]) -> list[psutil.Process]:
    """The processes of ``group`` and those ``known`` (in case one left the group) still
    running; a zombie has ended (only its exit status waits for whoever adopted it)."""
    processes = {p.pid: p for p in known}
    for process in psutil.process_iter():
        with contextlib.suppress(OSError):
            if os.getpgid(process.pid) == group:
                processes.setdefault(process.pid, process)
    running = []
    for process in processes.values():
        with contextlib.suppress(psutil.Error):
            if process.is_running() and process.status() != psutil.STATUS_ZOMBIE:
                running.append(process)
    return running


def _left_after(seconds: float, group: int, known: list[psutil.Process]) -> list[str]:
    """What of the run still runs ``seconds`` from now (killed then, so a failing test
    leaves nothing behind either): each one's command line."""
    deadline = time.monotonic() + seconds
    while (running := _running(group, known)) and time.monotonic() < deadline:
        time.sleep(0.05)
    left = []
    for process in running:
        with contextlib.suppress(psutil.Error):
            left.append(" ".join(process.cmdline())[:120])
            process.kill()
    return left


def _descendants(proc: subprocess.Popen[bytes]) -> list[psutil.Process]:
    with contextlib.suppress(psutil.Error):
        return psutil.Process(proc.pid).children(recursive=True)
    return []


def _started(proc: subprocess.Popen[bytes], helper: str = "spawn_main") -> bool:
    """Wait for the run's helper process: a spawned worker (its command line names
    ``spawn_main``), the figure drawer (``analysis.drawer``)."""
    deadline = time.monotonic() + 60
    while time.monotonic() < deadline and proc.poll() is None:
        for child in _descendants(proc):
            with contextlib.suppress(psutil.Error):
                if any(helper in part for part in child.cmdline()):
                    return True
        time.sleep(0.05)
    return False


def _stop(proc: subprocess.Popen[bytes]) -> None:
    with contextlib.suppress(ProcessLookupError):
        os.killpg(proc.pid, signal.SIGKILL)
    proc.wait(timeout=30)
    if proc.stdout is not None:
        proc.stdout.close()


def _end_of_output_within(seconds: float, proc: subprocess.Popen[bytes]) -> bool:
    """Whether the run's stdout reaches its end within ``seconds``: whether ``run ... |
    tee log`` returns (the pipe stays open while any process of the run holds it)."""
    assert proc.stdout is not None
    fd = proc.stdout.fileno()
    deadline = time.monotonic() + seconds
    while (remaining := deadline - time.monotonic()) > 0:
        if select.select([fd], [], [], remaining)[0] and not os.read(fd, 1 << 16):
            return True
    return False


#: When kill -9 comes, seeded: with --jobs 2, a moment from the start (before the worker
#: exists), or from the worker's start (it is importing; it is analysing or sending a
#: result); with --jobs 1, from the figure drawer's start (it is drawing).
_RNG = random.Random(43)
KILL_MOMENTS = [
    (2, "", round(_RNG.uniform(0.2, 0.5), 2)),
    (2, "spawn_main", round(_RNG.uniform(0.0, 0.6), 2)),
    (2, "spawn_main", round(_RNG.uniform(1.5, 3.0), 2)),
    (1, "analysis.drawer", round(_RNG.uniform(1.5, 3.0), 2)),
]


@pytest.mark.parametrize(("jobs", "helper", "after_s"), KILL_MOMENTS)
def test_kill_9_of_a_run_leaves_no_process(
    sessions: Path, tmp_path: Path, jobs: int, helper: str, after_s: float
) -> None:
    """And its stdout, a pipe, reaches its end: ``run ... | tee log`` returns."""
    err = tmp_path / "stderr"
    # The figure drawer runs only when static figures are asked for (issue 47).
    extra = ("--figures", "png") if helper == "analysis.drawer" else ()
    proc = _start(sessions, tmp_path / "out", err, jobs=jobs, stdout=subprocess.PIPE, extra=extra)
    try:
        if helper:
            assert _started(proc, helper), err.read_text()
        time.sleep(after_s)
        known = _descendants(proc)
        proc.kill()
        killed = time.monotonic()
        proc.wait(timeout=30)
        closed = _end_of_output_within(GONE_S, proc)
        left = _left_after(killed + GONE_S - time.monotonic(), proc.pid, known)
    finally:
        _stop(proc)
    assert closed, "a process of the killed run still holds its stdout"
    assert not left, f"still running {GONE_S:g} s after kill -9: {left}"
    assert "Traceback" not in err.read_text()


@pytest.mark.slow  # a run's process tree started and interrupted (~8 s): make test-all, CI
def test_an_interrupted_run_exits_130_and_leaves_no_process(sessions: Path, tmp_path: Path) -> None:
    """Ctrl-C to the run alone (not its group): its workers are stopped by it."""
    proc = _start(sessions, tmp_path / "out", tmp_path / "stderr")
    try:
        assert _started(proc), (tmp_path / "stderr").read_text()
        time.sleep(random.Random(2).uniform(0.5, 1.5))  # seeded: 0.5-1.5 s into the work
        known = _descendants(proc)
        proc.send_signal(signal.SIGINT)
        code = proc.wait(timeout=60)
        left = _left_after(GONE_S, proc.pid, known)
    finally:
        _stop(proc)
    err = (tmp_path / "stderr").read_text()
    assert code == 130, err
    assert "Traceback" not in err
    assert not left, f"still running {GONE_S:g} s after the run ended: {left}"


@pytest.mark.slow  # a run's process tree into a closed pipe (~8 s): make test-all, CI
def test_a_run_into_a_closed_pipe_leaves_no_process_and_no_traceback(
    sessions: Path, tmp_path: Path
) -> None:
    """``run ... | head -c 1``: the reader gone before anything is printed; the results
    are written all the same, and nothing runs on."""
    folder = tmp_path / "in"
    folder.mkdir()
    for path in sorted(sessions.glob("*.mcap"))[:2]:  # a whole run: its report is most of it
        os.link(path, folder / path.name)
    read, write = os.pipe()
    os.close(read)
    try:
        proc = _start(folder, tmp_path / "out", tmp_path / "stderr", stdout=write)
    finally:
        os.close(write)
    try:
        known: list[psutil.Process] = []
        deadline = time.monotonic() + 120
        while proc.poll() is None and time.monotonic() < deadline:
            known += [p for p in _descendants(proc) if p not in known]
            time.sleep(0.05)
        left = _left_after(GONE_S, proc.pid, known)
    finally:
        _stop(proc)
    err = (tmp_path / "stderr").read_text()
    assert "Traceback" not in err
    assert not left, f"still running {GONE_S:g} s after the run ended: {left}"
    assert (tmp_path / "out" / "report.html").exists(), err


@pytest.mark.parametrize("pidfd", [True, False], ids=["pidfd", "polled"])
def test_a_watched_child_ends_with_its_parent_killed(tmp_path: Path, pidfd: bool) -> None:
    """:func:`analysis.parent_watch.watch_parent` alone, by a pidfd and where there is none
    (``os.getppid()`` polled): the child of a killed parent is gone within a second."""
    child = (
        "import os, sys, time\n"
        + ("" if pidfd else "del os.pidfd_open\n")
        + (
            "from analysis.parent_watch import watch_parent\n"
            "watch_parent(int(sys.argv[1]))\n"
            "print('watching', flush=True)\n"
            "time.sleep(60)\n"
        )
    )
    parent = (
        "import os, subprocess, sys, time\n"
        f"subprocess.Popen([sys.executable, '-c', {child!r}, str(os.getpid())])\n"
        "time.sleep(60)\n"
    )
    proc = subprocess.Popen(
        [sys.executable, "-c", parent],
        stdout=subprocess.PIPE,
        env={**os.environ, "PYTHONPATH": str(REPO)},
        start_new_session=True,
    )
    try:
        assert proc.stdout is not None
        assert proc.stdout.readline() == b"watching\n"
        known = _descendants(proc)
        assert known
        proc.kill()
        proc.wait(timeout=30)
        closed = _end_of_output_within(1.0, proc)
        left = _left_after(0.5, proc.pid, known)
    finally:
        _stop(proc)
    assert closed, "the child outlived its parent by a second"
    assert not left, left


def test_a_child_whose_parent_is_already_gone_ends_at_once() -> None:
    code = (
        "import time\nfrom analysis.parent_watch import watch_parent\n"
        "watch_parent(1)\ntime.sleep(60)\n"  # pid 1 is not its parent: gone, as far as it knows
    )
    done = subprocess.run(
        [sys.executable, "-c", code],
        capture_output=True,
        env={**os.environ, "PYTHONPATH": str(REPO)},
        timeout=30,
    )
    assert done.returncode == EXIT_PARENT_GONE
    assert not done.stderr
