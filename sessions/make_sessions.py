"""Regenerate the bundled sample sessions (deterministic: same seeds, same sessions).

    python sessions/make_sessions.py sessions/

They mirror the thesis: method 1 (15 trials, 2 poses, 5 frames per pose), method 2
(15 trials, 5 frames), the line method (15 trials, 5 frames), and an averaging session
(3 trials with 50 frames per pose, the thesis' Figures 22-23).
"""

from __future__ import annotations

import sys
from dataclasses import dataclass
from pathlib import Path

from recorder.simulate import SimulationSummary, simulate_session


@dataclass(frozen=True)
class SampleSession:
    file: str
    method: str
    trials: int
    frames: int
    seed: int


SAMPLES = (
    SampleSession("method1_point.mcap", "point", trials=15, frames=5, seed=101),
    SampleSession("method2_ground.mcap", "ground", trials=15, frames=5, seed=102),
    SampleSession("line.mcap", "line", trials=15, frames=5, seed=103),
    SampleSession("averaging_ground.mcap", "ground", trials=3, frames=50, seed=104),
)


def make(sample: SampleSession, out_dir: Path) -> SimulationSummary:
    """Write one sample session into ``out_dir`` (the file must not exist yet)."""
    return simulate_session(
        out_dir / sample.file,
        method=sample.method,
        trials=sample.trials,
        frames=sample.frames,
        seed=sample.seed,
    )


def main(argv: list[str]) -> int:
    out_dir = Path(argv[1]) if len(argv) > 1 else Path(__file__).parent
    out_dir.mkdir(parents=True, exist_ok=True)
    for sample in SAMPLES:
        target = out_dir / sample.file
        if target.exists():
            target.unlink()  # this script owns the sample files, nothing else is replaced
        s = make(sample, out_dir)
        print(
            f"{s.path}: {s.method}, {s.n_trials} trials, {s.n_frames} frames, "
            f"{s.size_bytes / 1e6:.2f} MB"
        )
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv))
