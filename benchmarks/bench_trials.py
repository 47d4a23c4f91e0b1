"""Cost as the trial count grows: `twopose-analyze run` (defaults: tables, figures,
report, results MCAP) on a 500-trial session (10,000 frames) against a 100-trial one
(2,000 frames), both made of the same real frames.

    .venv/bin/python benchmarks/bench_trials.py [--workdir DIR] [--repeat 3]

Targets (issue 13, item 8):
1. the marginal cost of a frame, measured with the trials growing (so per-trial costs,
   figures among them, count), <= 2.5x the marginal cost of a bare decode loop;
2. the report (figures, CSV, report.html) costs the same whatever the trial count:
   writing it for 500 trials within 1.5x of writing it for 100.

Each timing is the best of ``--repeat`` fresh-process runs, interleaved. Exits 1 if a
target is missed.
"""

from __future__ import annotations

import argparse
import shutil
import sys
import tempfile
from pathlib import Path

from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from twopose.methods.specs import Method

sys.path.insert(0, str(Path(__file__).resolve().parent))

from bench_analysis import DECODE_LOOP, _python, count_frames, replicate  # type: ignore[import-not-found]  # on sys.path at run time

from recorder.simulate.one_camera import simulate_session

RUN_AND_REPORT = """
import sys, time
from pathlib import Path
from analysis.batch.runner import run, _thesis_sweeps
from analysis.report.writer import write_outputs
_thesis_sweeps()  # the seeded sweeps are cached per process: not part of either figure
t = time.perf_counter()
result = run([sys.argv[1]], sys.argv[2])
total = time.perf_counter() - t
assert not result.failed, result.errors
t = time.perf_counter()
write_outputs(result, Path(sys.argv[2]) / "again", _thesis_sweeps().copy())
print(total, time.perf_counter() - t)
"""

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "trials.txt"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--workdir", type=Path, default=None)
    parser.add_argument("--repeat", type=int, default=3)
    args = parser.parse_args()
    work = args.workdir or Path(tempfile.mkdtemp(prefix="twopose-trials-"))
    work.mkdir(parents=True, exist_ok=True)
    base = work / "base.mcap"
    if not base.exists():  # 20 trials x 2 poses x 10 frames = 400 real frames
        simulate_session(base, method=Method.GROUND, trials=20, frames=10, seed=13)
    small, large = work / "t100.mcap", work / "t500.mcap"
    for path, copies in ((small, 5), (large, 25)):
        if not path.exists():
            replicate(base, path, copies)
    n_small, n_large = count_frames(small), count_frames(large)

    timings: dict[str, list[float]] = {"dec_s": [], "dec_l": [], "run_s": [], "run_l": []}
    reports: dict[str, list[float]] = {"s": [], "l": []}
    for _ in range(args.repeat):  # interleaved: a slow spell of the machine hits all
        timings["dec_s"].append(_python(DECODE_LOOP, str(small))[0])
        timings["dec_l"].append(_python(DECODE_LOOP, str(large))[0])
        for key, path in (("s", small), ("l", large)):
            out = work / f"out_{key}"
            shutil.rmtree(out, ignore_errors=True)
            total, report, _cpu_s = _python(RUN_AND_REPORT, str(path), str(out))
            timings[f"run_{key}"].append(total)
            reports[key].append(report)
    best = {k: min(v) for k, v in timings.items()}
    m_dec = (best["dec_l"] - best["dec_s"]) / (n_large - n_small) * 1e3
    m_run = (best["run_l"] - best["run_s"]) / (n_large - n_small) * 1e3
    ratio = m_run / m_dec
    report_s, report_l = min(reports["s"]), min(reports["l"])
    print(
        f"{n_small} frames (100 trials) -> {n_large} frames (500 trials): marginal ms/frame "
        f"decode {m_dec:.2f}, run {m_run:.2f}, ratio {ratio:.2f} (target <= 2.5)"
    )
    print(
        f"report (figures, CSV, report.html): 100 trials {report_s:.2f} s, 500 trials "
        f"{report_l:.2f} s, ratio {report_l / report_s:.2f} (target <= 1.5)"
    )
    return 0 if ratio <= 2.5 and report_l / report_s <= 1.5 else 1


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
