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

from analysis.batch.parent_watch import EXIT_PARENT_GONE
from tests.helpers import distinct_copies
from twopose.errors import EXIT_CLOSED_PIPE

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
    ``spawn_main``), the figure drawer (``analysis.report.figures.drawer``)."""
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
    (1, "analysis.report.figures.drawer", round(_RNG.uniform(1.5, 3.0), 2)),
]


@pytest.mark.parametrize(("jobs", "helper", "after_s"), KILL_MOMENTS)
def test_kill_9_of_a_run_leaves_no_process(
    sessions: Path, tmp_path: Path, jobs: int, helper: str, after_s: float
) -> None:
    """And its stdout, a pipe, reaches its end: ``run ... | tee log`` returns."""
    err = tmp_path / "stderr"
    # The figure drawer runs only when static figures are asked for (issue 47).
    extra = ("--figures", "png") if helper == "analysis.report.figures.drawer" else ()
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
    said = err.read_text()
    assert "Traceback" not in said
    # Issue 56: multiprocessing's resource tracker removed the pool's semaphores after the
    # kill, saying "resource_tracker: There appear to be 6 leaked semaphore objects".
    assert "resource_tracker" not in said, said


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


@pytest.mark.slow  # a run's process tree into a closed pipe (~4 s): make test-all, CI
@pytest.mark.parametrize("reader", ["gone", "head -1"])
def test_a_run_into_a_closed_pipe_stops_there_without_a_trace(
    sessions: Path, tmp_path: Path, reader: str
) -> None:
    """``run ... | head -1``: the run says how many sessions it analyses where at once, and
    once nobody reads on, it stops at its next line (issue 56: it analysed the whole batch
    first) and ends with 141, ``--out`` as it was, no traceback and nothing running on;
    the reader gone before anything is printed, it stops before the first session."""
    read, write = os.pipe()
    if reader == "gone":
        os.close(read)
    try:
        proc = _start(sessions, tmp_path / "out", tmp_path / "stderr", stdout=write)
    finally:
        os.close(write)
    try:
        if reader == "head -1":
            with os.fdopen(read, "rb") as pipe:  # head -1: one line, then the pipe closed
                assert pipe.readline().startswith(b"twopose: analysing 12 session(s) into ")
        known: list[psutil.Process] = []
        deadline = time.monotonic() + 120
        while proc.poll() is None and time.monotonic() < deadline:
            known += [p for p in _descendants(proc) if p not in known]
            time.sleep(0.05)
        left = _left_after(GONE_S, proc.pid, known)
    finally:
        _stop(proc)
    err = (tmp_path / "stderr").read_text()
    assert proc.returncode == EXIT_CLOSED_PIPE, err
    assert "Traceback" not in err
    assert not left, f"still running {GONE_S:g} s after the run ended: {left}"
    assert not (tmp_path / "out" / "trials.csv").exists(), err  # the batch was not finished


@pytest.mark.slow  # a worker started (~3 s): make test-all, CI
def test_a_ctrl_c_ends_the_session_a_worker_has_in_hand(tmp_path: Path) -> None:
    """Issue 56: a Ctrl-C let the worker finish the session in hand, up to a fixed 5 s,
    before ending it (0.37-6.04 s to the prompt). Two sessions that never end (FIFOs: an
    analysis blocks reading them), one in the worker, one here: a Ctrl-C to this process
    ends both at once (the worker's by the Ctrl-C passed on to it), not after 5 s."""
    import threading

    from analysis.batch.runner import _Batch
    from analysis.batch.workers import run_processes
    from analysis.results import AnalysisOptions

    fifos = [tmp_path / f"never{k}.mcap" for k in range(2)]
    for fifo in fifos:
        os.mkfifo(fifo)
    options = AnalysisOptions(session_timeout_s=None)
    files = [str(f) for f in fifos]
    batch = _Batch(files=files, results_mcap=[None, None], options=options, images=False,
                   on_done=None)  # fmt: skip
    writer: list[int] = []
    signalled: list[float] = []

    def interrupt_once_the_worker_reads() -> None:
        deadline = time.monotonic() + 120
        while not writer and time.monotonic() < deadline:  # a writer opens once it reads
            with contextlib.suppress(OSError):
                writer.append(os.open(fifos[0], os.O_WRONLY | os.O_NONBLOCK))
            time.sleep(0.02)
        time.sleep(0.3)  # it reads, and waits for bytes that never come
        signalled.append(time.monotonic())
        os.kill(os.getpid(), signal.SIGINT)

    previous = signal.signal(signal.SIGINT, signal.default_int_handler)  # xdist ignores it
    try:
        threading.Thread(target=interrupt_once_the_worker_reads, daemon=True).start()
        with pytest.raises(KeyboardInterrupt):
            run_processes(batch, 2)
        took = time.monotonic() - signalled[0]
    finally:
        signal.signal(signal.SIGINT, previous)
        for fd in writer:
            os.close(fd)
    assert writer, "the worker never read its session"
    assert took < 2.5, f"{took:.2f} s from the Ctrl-C to the workers' end"


@pytest.mark.parametrize("pidfd", [True, False], ids=["pidfd", "polled"])
def test_a_watched_child_ends_with_its_parent_killed(tmp_path: Path, pidfd: bool) -> None:
    """:func:`analysis.batch.parent_watch.watch_parent` alone, by a pidfd and where there is none
    (``os.getppid()`` polled): the child of a killed parent is gone within a second."""
    child = (
        "import os, sys, time\n"
        + ("" if pidfd else "del os.pidfd_open\n")
        + (
            "from analysis.batch.parent_watch import watch_parent\n"
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
        "import time\nfrom analysis.batch.parent_watch import watch_parent\n"
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
