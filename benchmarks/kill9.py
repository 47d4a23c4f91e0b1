"""kill -9 the real recorder at random moments, recover, and check what the analysis gets.

Each run starts ``python -m recorder new OUT --plan PLAN --source synthetic`` (the camera
paced at 30 fps), sends SIGKILL after a random delay, runs ``recover`` on what is left and
replays it as the analysis does. Every replayed (pose, frames) pair must be one the plan
accepted, in plan order (a prefix of the plan), with all its frames; nothing undecided or
in progress may be used. Prints the figures quoted in the README and the issue notes.

    python benchmarks/kill9.py [--runs 40] [--seed 0]
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np
from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from recorder.recover import recover_session  # noqa: E402
from twopose.errors import SessionFormatError  # noqa: E402
from twopose.format.reader import SessionReader  # noqa: E402
from twopose.format.trials import iter_trials  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "kill9.txt"

TRIALS, FRAMES = 4, 15
POSES = [((0.0, 0.0, 0.0), (1.1, 0.0, 0.0))] * TRIALS


def plan_text() -> str:
    trials = "".join(
        "[[trials]]\nground_truth = [[0.5, 1.5, 11.0]]\n"
        f"poses = [{{ t = {list(a)} }}, {{ t = {list(b)} }}]\n"
        for a, b in POSES
    )
    return f'method = "point"\nframes = {FRAMES}\n[camera]\nfocal = 525.0\n{trials}'


def expected_order() -> list[tuple[int, int, float]]:
    return [(t, p, POSES[t - 1][p - 1][0]) for t in range(1, TRIALS + 1) for p in (1, 2)]


def replayed(path: Path) -> list[tuple[int, int, float, int]]:
    with SessionReader(path) as reader:
        return [
            (t.trial, p.entry.pose, p.entry.t_grid[0], len(p.frames))
            for t in iter_trials(reader)
            for p in t.poses
        ]


def one_run(folder: Path, plan: Path, delay_s: float, i: int) -> dict[str, int]:
    """One recording killed after ``delay_s``; the checks, and what survived."""
    out, fixed = folder / f"s{i}.mcap", folder / f"fixed{i}.mcap"
    env = {**os.environ, "PYTHONPATH": str(REPO)}
    cmd = [sys.executable, "-m", "recorder", "new", str(out), "--plan", str(plan)]
    proc = subprocess.Popen(
        [*cmd, "--source", "synthetic"],
        stdout=subprocess.PIPE,
        stderr=subprocess.DEVNULL,
        text=True,
        env=env,
    )
    deadline = time.monotonic() + 30
    while not out.exists() and time.monotonic() < deadline:  # the session is open
        time.sleep(0.01)
    time.sleep(delay_s)
    proc.send_signal(signal.SIGKILL)
    stdout, _ = proc.communicate()
    reported = sum(line.startswith("trial ") for line in stdout.splitlines())
    try:
        report = recover_session(out, fixed)
    except SessionFormatError as err:  # killed before the opening entries reached the disk
        if "no 'twopose' metadata record" not in str(err) or reported:
            raise
        return {"killed_before_the_session_opened": 1}
    pairs = replayed(fixed)
    order = expected_order()
    assert [(t, p, x) for t, p, x, _ in pairs] == order[: len(pairs)], pairs
    assert all(n == FRAMES for *_, n in pairs), pairs
    assert len(pairs) >= reported - 1, (len(pairs), reported)  # at most the last undecided
    return {
        "accepted_kept": len(pairs),
        "captures_reported": reported,
        "in_progress_closed": report.closed_captures,
        "chunks_lost": report.chunks_lost,
        "truncated": int(report.truncated),
    }


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=40)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = np.random.default_rng(args.seed)
    totals: dict[str, int] = {}
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        plan = folder / "plan.toml"
        plan.write_text(plan_text())
        for i in range(args.runs):
            result = one_run(folder, plan, float(rng.uniform(0.0, 4.0)), i)
            for key, value in result.items():
                totals[key] = totals.get(key, 0) + value
    print(f"python benchmarks/kill9.py --runs {args.runs} --seed {args.seed}")
    print(
        f"{args.runs} kill -9 at random moments (0-4 s after the session file opened, "
        f"{TRIALS}-trial plan): every recovered file replays a prefix of the plan's accepted "
        "captures, whole"
    )
    for key, value in sorted(totals.items()):
        print(f"  {key}: {value}")
    return 0


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
