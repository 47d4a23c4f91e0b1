"""Speed-up of a batch on a real Dask cluster: a ``dask scheduler`` with 2 ``dask worker``
processes against 1, on loopback, on a batch of many small sessions (the workers are
warmed up first, as a running cluster would be).

    python benchmarks/bench_dask.py [--sessions 16] [--trials 5] [--frames 10]
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from pathlib import Path

from doc_figures import run_recorded  # type: ignore[import-not-found]  # benchmarks/ is sys.path[0]

from twopose.methods.specs import Method

REPO = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(REPO))

from analysis.batch.runner import run  # noqa: E402
from recorder.simulate.one_camera import simulate_session  # noqa: E402
from tests.helpers import DaskCluster  # noqa: E402

#: The docs include this file (``--write-docs`` writes it).
FIGURE = "dask.txt"


def batch_seconds(paths: list[Path], folder: Path, workers: int) -> float:
    cluster = DaskCluster(folder, workers)
    try:
        started = time.perf_counter()
        result = run(paths, None, dask_address=cluster.address)
        seconds = time.perf_counter() - started
    finally:
        cluster.close()
    assert result.errors.empty, result.errors
    return seconds


def _folder(parent: Path, workers: int) -> Path:
    folder = parent / f"cluster{workers}"
    folder.mkdir()
    return folder


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--sessions", type=int, default=16)
    parser.add_argument("--trials", type=int, default=5)
    parser.add_argument("--frames", type=int, default=10)
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp)
        paths = [folder / f"s{k:02d}.mcap" for k in range(args.sessions)]
        for k, path in enumerate(paths):
            method = ("point", "line", "ground")[k % 3]
            simulate_session(
                path, method=Method(method), trials=args.trials, frames=args.frames, seed=k
            )
        one, two = (batch_seconds(paths, _folder(folder, n), n) for n in (1, 2))
    frames = args.sessions * args.trials * 2 * args.frames
    print(
        f"{args.sessions} sessions ({frames} frames) on {os.cpu_count()} cores: "
        f"1 Dask worker {one:.1f} s, 2 workers {two:.1f} s, speed-up {one / two:.2f}x"
    )
    return 0


if __name__ == "__main__":
    raise SystemExit(run_recorded(main, FIGURE))
