"""Stop `twopose-analyze run --jobs 2` at random moments: how long the prompt takes (issue 56).

Each run analyses the bundled sessions (``--no-reuse``: every session is analysed) into a
results folder a complete earlier run wrote, in a process group of its own, and gets, after
a random delay, one of: Ctrl-C to its process group (what a terminal sends), SIGINT or
SIGTERM to the run alone, or kill -9 to the run alone. Every stop must leave the previous
results byte for byte, no process of the run behind, no traceback and no
``resource_tracker`` warning; a Ctrl-C or SIGTERM must exit 130 within 1 s (the target; it
took 0.37 to 6.04 s before: the workers were given 5 s to finish the sessions in hand).
Prints the distribution of the seconds from the signal to the run's exit, per stop.

    python benchmarks/bench_run_stop.py [--runs 24] [--seed 0] [--longest 12] [--write-docs]
"""

from __future__ import annotations

import argparse
import hashlib
import os
import random
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
import psutil
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

REPO = Path(__file__).resolve().parents[1]
FIGURE = "run_stop.txt"
#: The target: a stop's exit within this many seconds of the signal.
TARGET_S = 1.0
STOPS = {
    "Ctrl-C to the group": (signal.SIGINT, True),
    "SIGINT to the run": (signal.SIGINT, False),
    "SIGTERM to the run": (signal.SIGTERM, False),
    "kill -9 to the run": (signal.SIGKILL, False),
}


def _results(folder: Path) -> dict[str, str]:
    """Every result file under ``folder`` and its SHA-256: the re-run cache apart, and the
    staging folder a run killed outright leaves (the next run into the folder removes it)."""
    aside = {".twopose-cache", ".twopose-staging"}
    return {
        str(p.relative_to(folder)): hashlib.sha256(p.read_bytes()).hexdigest()
        for p in sorted(folder.rglob("*"))
        if p.is_file() and not aside & set(p.relative_to(folder).parts)
    }


def _group_left(group: int, deadline_s: float) -> list[str]:
    """The processes of ``group`` still running ``deadline_s`` from now (then killed)."""
    end = time.monotonic() + deadline_s
    while True:
        left = []
        for process in psutil.process_iter():
            try:
                if os.getpgid(process.pid) == group and process.status() != psutil.STATUS_ZOMBIE:
                    left.append(process)
            except (OSError, psutil.Error):
                continue
        if not left or time.monotonic() > end:
            break
        time.sleep(0.05)
    for process in left:
        try:
            process.kill()
        except psutil.Error:
            continue
    return [f"{p.pid}" for p in left]


def one_stop(out: Path, stop: str, delay: float, err: Path) -> float:
    """One run stopped ``delay`` s after its start; the seconds from the signal to its exit.
    Raises AssertionError when the stop broke a rule (module docstring)."""
    before = _results(out)
    number, to_group = STOPS[stop]
    with open(err, "wb") as stderr:
        proc = subprocess.Popen(
            [sys.executable, "-m", "analysis", "run", str(REPO / "sessions"), "--out", str(out),
             "--jobs", "2", "--no-reuse"],
            stdout=subprocess.DEVNULL, stderr=stderr, start_new_session=True,
            env={**os.environ, "PYTHONPATH": str(REPO)},
        )  # fmt: skip
    time.sleep(delay)
    if proc.poll() is not None:
        raise AssertionError(f"the run ended before the signal ({delay:.1f} s): use --longest")
    signalled = time.monotonic()
    if to_group:
        os.killpg(proc.pid, number)
    else:
        os.kill(proc.pid, number)
    code = proc.wait(timeout=60)
    took = time.monotonic() - signalled
    left = _group_left(proc.pid, 5.0)
    said = err.read_text(errors="replace")
    assert not left, f"processes of the run still running 5 s after it: {left}"
    assert "Traceback" not in said, said
    assert "resource_tracker" not in said, said
    assert code == (-signal.SIGKILL if number == signal.SIGKILL else 130), (code, said)
    assert _results(out) == before, "the previous results changed"
    return took


def main() -> int:
    """Stop ``--runs`` runs; 0 when every stop kept the rules and met the target."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=24)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--longest", type=float, default=12.0, help="the latest signal, s")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    took: dict[str, list[float]] = {stop: [] for stop in STOPS}
    failed = 0
    with tempfile.TemporaryDirectory() as folder:
        out = Path(folder) / "results"
        subprocess.run(
            [sys.executable, "-m", "analysis", "run", str(REPO / "sessions"), "--out", str(out)],
            check=True, capture_output=True, env={**os.environ, "PYTHONPATH": str(REPO)},
        )  # fmt: skip
        for k in range(args.runs):
            stop = list(STOPS)[k % len(STOPS)]
            delay = rng.uniform(0.5, args.longest)
            try:
                took[stop].append(one_stop(out, stop, delay, Path(folder) / f"err{k}"))
            except AssertionError as err:
                failed += 1
                print(f"run {k} ({stop} at {delay:.1f} s) FAILED: {str(err)[-300:]}")
    print(
        f"{args.runs} runs of `run sessions/ --jobs 2` stopped at 0.5-{args.longest:g} s, "
        f"{failed} failed; seconds from the signal to the exit (target <= {TARGET_S:g} s "
        "for a Ctrl-C or SIGTERM):"
    )
    late = 0
    for stop, times in took.items():
        if times:
            q = np.percentile(times, [50, 95, 100])
            print(f"  {stop}: {len(times)} runs, median {q[0]:.2f}, p95 {q[1]:.2f}, max {q[2]:.2f}")
            if STOPS[stop][0] != signal.SIGKILL:
                late += sum(t > TARGET_S for t in times)
    return 1 if failed or late else 0


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
