"""Regenerate the bundled sample sessions (deterministic: same seeds, same sessions).

    python sessions/make_sessions.py sessions/

``thesis_*`` mirror the thesis' experiments: 15 trials of 2 poses and 5 frames per pose,
the laptop moved along x only or along x and depth (section 5.3), typed to 1/8 in with a
0.1 in placing error, in its geometry (f = 525 px, h = 9.625 in, its targets); the line
method in the same geometry (the thesis did not test it); and the averaging experiment
(3 trials with 50 frames per pose, Figures 22-23). ``stress_*`` draw each pose anywhere
in a wide range, so that some trials come near a degenerate geometry: the tool's warnings
and their effect on the summary.
"""

from __future__ import annotations

import dataclasses
import sys
from dataclasses import dataclass
from pathlib import Path

from recorder.simulate import SimulationSummary, simulate_session
from twopose.sim.scene import PoseParams, Scene


@dataclass(frozen=True)
class SampleSession:
    file: str
    method: str
    trials: int
    frames: int
    seed: int
    thesis: bool  # the thesis' moves and typing lattice, or free poses (stress)


SAMPLES = (
    SampleSession("thesis_method1_point.mcap", "point", 15, 5, seed=201, thesis=True),
    SampleSession("thesis_method2_ground.mcap", "ground", 15, 5, seed=202, thesis=True),
    SampleSession("thesis_line.mcap", "line", 15, 5, seed=203, thesis=True),
    SampleSession("thesis_averaging_ground.mcap", "ground", 3, 50, seed=204, thesis=True),
    SampleSession("stress_method1_point.mcap", "point", 15, 5, seed=101, thesis=False),
    SampleSession("stress_method2_ground.mcap", "ground", 15, 5, seed=102, thesis=False),
    SampleSession("stress_line.mcap", "line", 15, 5, seed=103, thesis=False),
)

#: The thesis' procedure: moves along x, or x and depth; typed to 1/8 in.
THESIS_POSES = dataclasses.replace(PoseParams(), moves="thesis", step=0.125, noise_sigma=0.04)


def make(sample: SampleSession, out_dir: Path) -> SimulationSummary:
    """Write one sample session into ``out_dir`` (the file must not exist yet)."""
    return simulate_session(
        out_dir / sample.file,
        method=sample.method,
        trials=sample.trials,
        frames=sample.frames,
        seed=sample.seed,
        scene=Scene(poses=THESIS_POSES) if sample.thesis else None,
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
