"""Shared fixtures: small real sessions written through the real writer and simulator."""

from __future__ import annotations

from pathlib import Path

import pytest

from recorder.simulate import simulate_session

REPO = Path(__file__).resolve().parents[1]
SESSIONS = REPO / "sessions"


@pytest.fixture(scope="session")
def sim_dir(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tmp_path_factory.mktemp("sim")


@pytest.fixture(scope="session")
def ground_session(sim_dir: Path) -> Path:
    """A small simulated method-2 session: 2 trials x 2 poses x 3 frames."""
    out = sim_dir / "ground.mcap"
    simulate_session(out, method="ground", trials=2, frames=3, seed=7)
    return out


@pytest.fixture(scope="session")
def point_session(sim_dir: Path) -> Path:
    out = sim_dir / "point.mcap"
    simulate_session(out, method="point", trials=2, frames=3, seed=8)
    return out
