"""benchmarks/bench_run.py exits 1 when a target is missed (issue 47): figures' share of a
run's CPU, a re-run's CPU, a frame's marginal wall time; its timings given here."""

from __future__ import annotations

import sys
from pathlib import Path
from typing import Any

import pytest

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


@pytest.fixture
def bench_run(monkeypatch: pytest.MonkeyPatch) -> Any:
    monkeypatch.syspath_prepend(str(BENCHMARKS))
    import bench_run  # type: ignore[import-not-found]  # benchmarks/ is not a package

    return bench_run


def _measured(b: Any, *, free: float, rerun: float, run_l_wall: float) -> Any:
    """One size (a 100-frame batch) run in 10 CPU-seconds, and the marginal frame's runs
    between 100 and 200 frames against a decode of 1 ms a frame."""

    def t(cpu: float = 1.0, wall: float = 1.0) -> Any:
        return b.Timing(cpu=cpu, wall=wall, process_cpu=wall)

    modes = {"run": t(10.0), "free": t(free), "rerun": t(rerun), "figures": b.Timing()}
    frame = {"run_s": t(), "run_l": t(wall=run_l_wall), "dec_s": t(), "dec_l": t(wall=1.1)}
    frames = {"batch": 100, "small": 100, "large": 200}
    return b.Measured({"batch": modes}, frame, frames)


@pytest.mark.parametrize(
    ("free", "rerun", "run_l_wall", "code"),
    [
        (9.0, 1.5, 1.15, 0),  # figures 10%, re-run 15%, a frame 1.5x a decode
        (8.0, 1.5, 1.15, 1),  # figures 20% of the CPU
        (9.0, 3.0, 1.15, 1),  # a re-run 30% of the first run
        (9.0, 1.5, 1.25, 1),  # a frame 2.5x a decode
    ],
)
def test_the_benchmark_exits_1_when_a_target_is_missed(
    bench_run: Any,
    tmp_path: Path,
    monkeypatch: pytest.MonkeyPatch,
    capsys: pytest.CaptureFixture[str],
    free: float,
    rerun: float,
    run_l_wall: float,
    code: int,
) -> None:
    b, size = bench_run, bench_run.Size
    sizes = ([size("batch", Path)], (size("small", Path), size("large", Path)))
    measured = _measured(b, free=free, rerun=rerun, run_l_wall=run_l_wall)
    monkeypatch.setattr(b, "FULL", sizes)
    monkeypatch.setattr(b, "measure_sizes", lambda *args, **kwargs: measured)
    monkeypatch.setattr(sys, "argv", ["bench_run.py", "--workdir", str(tmp_path)])
    assert b.main() == code
    printed = capsys.readouterr().out
    assert "of the CPU (target <= 15%)" in printed
    assert "of the first run's (target <= 20%)" in printed
    assert "wall (target <= 2)" in printed
