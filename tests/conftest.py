"""Shared fixtures: small real sessions written through the real writer and simulator."""

from __future__ import annotations

from pathlib import Path

import pytest

from recorder.simulate import simulate_session
from twopose.methods import Method

REPO = Path(__file__).resolve().parents[1]
SESSIONS = REPO / "sessions"


@pytest.fixture(scope="session")
def sim_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("sim")


@pytest.fixture(scope="session")
def ground_session(sim_dir: Path) -> Path:
    """A small simulated method-2 session: 2 trials x 2 poses x 3 frames."""
    out = sim_dir / "ground.mcap"
    simulate_session(out, method=Method.GROUND, trials=2, frames=3, seed=7)
    return out


@pytest.fixture(scope="session")
def point_session(sim_dir: Path) -> Path:
    out = sim_dir / "point.mcap"
    simulate_session(out, method=Method.POINT, trials=2, frames=3, seed=8)
    return out


@pytest.fixture(scope="session")
def line_session(sim_dir: Path) -> Path:
    out = sim_dir / "line.mcap"
    simulate_session(out, method=Method.LINE, trials=2, frames=3, seed=9)
    return out


@pytest.fixture(scope="session")
def exact_sessions(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One session per method with no pose-typing error: only detection error remains."""
    folder = tmp_path_factory.mktemp("exact")
    for seed, method in enumerate(("point", "line", "ground")):
        simulate_session(
            folder / f"{method}.mcap",
            method=Method(method),
            trials=4,
            frames=2,
            seed=20 + seed,
            pose_noise=0.0,
        )
    return folder


@pytest.fixture(scope="session")
def bundled_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The --out folder of ``make run``'s job on the bundled sessions (without the Foxglove
    files), made once for the tests that read it."""
    import analysis

    out = tmp_path_factory.mktemp("bundled") / "results"
    analysis.run([SESSIONS], out, scene=False)
    return out
