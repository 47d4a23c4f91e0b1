"""Stop real recorders on the slow paths at random moments (issue 55, 2): every stop within 2 s.

The paths issue 44's sweep (``benchmarks/stops.py``) did not walk, with the default synthetic
scene (640x480, supersampled: the slow camera): just after a typed pose (its view being
cast), just after the page's setup (the camera opened and its first view cast for the
page's live image), while a large session is continued (a bundled 7.9 MB session with six
copies beside it: read, identified, the camera opened) and in the command's first tenths of
a second. Each run sends Ctrl-C, a quick double Ctrl-C, SIGTERM or SIGHUP at a random moment
of the slow step and checks what ``tests/recorder/test_slow_stops.py`` checks (exit 130
within 2 s, no traceback, the file readable or none; the continued session untouched).
Before issue 55 these took 1.67-2.38 s (a typed pose), 1.97-2.69 s (the setup), 2.6-3.6 s
(continuing), and a signal in the first 0.3 s printed a traceback or killed the process.

    python benchmarks/stops_slow.py [--runs 24] [--seed 0] [--write-docs]
"""

from __future__ import annotations

import argparse
import random
import sys
import tempfile
from pathlib import Path

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from doc_figures import run_recorded  # type: ignore[import-not-found]  # noqa: E402
from stops import report  # type: ignore[import-not-found]  # noqa: E402

from tests.recorder import test_slow_stops as slow  # noqa: E402
from tests.recorder import test_stops as t  # noqa: E402

FIGURE = "stops_slow.txt"


def main() -> int:
    """Stop ``--runs`` recorders on the slow paths; 0 if every stop was in time."""
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=int, default=24)
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    rng = random.Random(args.seed)
    took: dict[str, list[float]] = {name: [] for name in slow.PATHS}
    failed = 0
    with tempfile.TemporaryDirectory() as folder:
        for k in range(args.runs):
            path = list(took)[k % len(took)]
            name = rng.choice(list(t.SIGNALS))
            delay = rng.uniform(0.0, 0.05 if path == "the first tenths" else 0.3)
            tmp = Path(folder) / f"run{k}"
            tmp.mkdir()
            try:
                took[path].append(slow.PATHS[path](tmp, t.SIGNALS[name], delay))
            except AssertionError as err:
                failed += 1
                print(f"run {k} ({path}, {name} at {delay:.2f} s) FAILED: {str(err)[-300:]}")
    return report(took, failed, "exit 130")


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
