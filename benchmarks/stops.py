"""Stop real recorders at random moments: every stop must close the file (issue 44, part 1).

Each run starts ``twopose-record new`` with the synthetic camera's small scene, driven by a
random operator at the terminal, by a plan, or in the browser console (through its API),
and sends one of Ctrl-C, a quick double Ctrl-C, SIGTERM or SIGHUP after a random delay.
Every run must exit 130 within 2 s of the signal, print the summary once, and leave a file
that opens without ``recover`` holding every capture accepted before the signal (the
checks of ``tests/recorder/test_stops.py``, which runs twelve of these). Prints the
distribution of the time from the signal to the exit, per front end.

    python benchmarks/stops.py [--runs 48] [--seed 0] [--longest 8] [--write-docs]
"""

from __future__ import annotations

import argparse
import random
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from doc_figures import run_recorded  # type: ignore[import-not-found]  # noqa: E402

from tests.helpers import SMALL_SCENE  # noqa: E402
from tests.recorder import test_stops as t  # noqa: E402


def one_run(tmp: Path, scene: str, front: str, name: str, delay: float, seed: int) -> float:
    """One recorder stopped after ``delay`` s; the seconds from the signal to its exit."""
    rng = random.Random(seed)
    out = tmp / "s.mcap"
    acked = [0]
    if front == "terminal":
        args = [str(out), "--source", scene, *t.SMALL, *t.SETUP, "--frames", "3"]
        rec = t.Recorder(args, stdin=True)
        rec.wait_for("recording")
        script = t.terminal_operator(rec, rng, acked)
    elif front == "plan":
        rec = t.Recorder([str(out), "--plan", str(t._plan(tmp, trials=40)), "--source", scene])
        rec.wait_for("recording|trial 1")
        script = t._count_plan_accepts(rec, acked)
    else:
        rec = t.Recorder([str(out), "--ui", "--source", scene, *t.SMALL, "--frames", "3"])
        rec.wait_for(r"http://\S+/")
        url = rec.text[rec.text.index("http://") :].split()[0]
        script = t.console_operator(url, rng, acked)
    t._in_background(script)
    time.sleep(delay)
    seen = acked[0]
    rec.send(t.SIGNALS[name])
    t.check_stopped(rec, out, seen)
    return rec.exited_at - rec.signalled_at


FIGURE = "stops.txt"


def main() -> int:
    """Stop ``--runs`` recorders; 0 if every stop closed its file in time."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=48)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--longest", type=float, default=8.0, help="the latest signal, s")
    args = parser.parse_args()
    rng = random.Random(args.seed)
    took: dict[str, list[float]] = {"terminal": [], "plan": [], "console": []}
    failed = 0
    with tempfile.TemporaryDirectory() as folder:
        scene_path = Path(folder) / "small.toml"
        scene_path.write_text(SMALL_SCENE)
        for k in range(args.runs):
            front = list(took)[k % 3]
            name = rng.choice(list(t.SIGNALS))
            delay = rng.uniform(0.2, args.longest)
            tmp = Path(folder) / f"run{k}"
            tmp.mkdir()
            try:
                took[front].append(one_run(tmp, f"synthetic:{scene_path}", front, name, delay, k))
            except AssertionError as err:
                failed += 1
                print(f"run {k} ({front}, {name} at {delay:.1f} s) FAILED: {str(err)[-300:]}")
    return report(took, failed, "file closed")


def report(took: dict[str, list[float]], failed: int, after: str) -> int:
    """Print the sweep's times from the signal to the exit, per kind of run; 1 if a run
    failed (``benchmarks/stops_slow.py`` reports its paths so too)."""
    runs = sum(map(len, took.values())) + failed
    print(f"{runs} runs, {failed} failed; seconds from the signal to the exit ({after}):")
    for kind, times in took.items():
        if times:
            q = np.percentile(times, [50, 95, 100])
            print(f"  {kind}: {len(times)} runs, median {q[0]:.2f}, p95 {q[1]:.2f}, max {q[2]:.2f}")
    return 1 if failed else 0


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
