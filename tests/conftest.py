"""Shared fixtures: small real sessions written through the real writer and simulator.

Each is built once per test run, not once per pytest-xdist worker (:func:`built_once`):
the workers share the run's temporary root, and whichever asks first builds while the
other waits for it. Tests read them and never write into them.
"""

from __future__ import annotations

import os
import shutil
from collections.abc import Callable
from pathlib import Path

import pytest

from recorder.simulate.one_camera import simulate_session
from twopose.methods.specs import Method

REPO = Path(__file__).resolve().parents[1]
SESSIONS = REPO / "sessions"


@pytest.fixture(autouse=True)
def _operator_noise_apart(
    monkeypatch: pytest.MonkeyPatch, tmp_path_factory: pytest.TempPathFactory
) -> None:
    """Every test's recordings keep their operators' noise files in a folder of its own
    (recorder.live.operator_noise), never the user's, never another test's: created when first
    written, so a test that records nothing pays nothing."""
    import uuid

    folder = tmp_path_factory.getbasetemp() / "operator-noise" / uuid.uuid4().hex
    monkeypatch.setenv("TWOPOSE_NOISE_DIR", str(folder))


def built_once(
    tmp_path_factory: pytest.TempPathFactory, name: str, build: Callable[[Path], None]
) -> Path:
    """The folder ``name``, filled by ``build(folder)`` once per test run: under pytest-xdist
    in the workers' common temporary root, under a lock (the first worker to ask builds it,
    the others wait and reuse it); in one process, in its own temporary root."""
    root = tmp_path_factory.getbasetemp()
    if os.environ.get("PYTEST_XDIST_WORKER"):
        root = root.parent  # pytest-of-<user>/pytest-<n>: every worker's basetemp is in it
    folder, done = root / f"shared-{name}", root / f"shared-{name}.done"
    try:
        import fcntl
    except ImportError:  # no flock (Windows): one build per process
        return _build(tmp_path_factory.mktemp(name), build)
    with open(root / f"shared-{name}.lock", "w") as lock:
        fcntl.flock(lock, fcntl.LOCK_EX)
        if not done.exists():
            shutil.rmtree(folder, ignore_errors=True)
            _build(folder, build)
            done.touch()
    return folder


def _build(folder: Path, build: Callable[[Path], None]) -> Path:
    folder.mkdir(parents=True, exist_ok=True)
    build(folder)
    return folder


def _simulated(tmp_path_factory: pytest.TempPathFactory, name: str) -> Path:
    """One of the three small sessions, all in one folder (a session's label in a run's
    messages is its path from the inputs' common folder: here, its file name)."""

    def build(folder: Path) -> None:
        for method, seed in ((Method.GROUND, 7), (Method.POINT, 8), (Method.LINE, 9)):
            path = folder / f"{method.value}.mcap"
            simulate_session(path, method=method, trials=2, frames=3, seed=seed)

    return built_once(tmp_path_factory, "sim", build) / f"{name}.mcap"


@pytest.fixture(scope="session")
def ground_session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A small simulated method-2 session: 2 trials x 2 poses x 3 frames."""
    return _simulated(tmp_path_factory, "ground")


@pytest.fixture(scope="session")
def point_session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _simulated(tmp_path_factory, "point")


@pytest.fixture(scope="session")
def line_session(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return _simulated(tmp_path_factory, "line")


@pytest.fixture(scope="session")
def exact_sessions(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """One session per method with no pose-typing error: only detection error remains."""

    def build(folder: Path) -> None:
        for seed, method in enumerate(("point", "line", "ground")):
            simulate_session(
                folder / f"{method}.mcap",
                method=Method(method),
                trials=4,
                frames=2,
                seed=20 + seed,
                pose_noise=0.0,
            )

    return built_once(tmp_path_factory, "exact", build)


@pytest.fixture(scope="session")
def bundled_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """The --out folder of ``make run``'s job on the bundled sessions (without the Foxglove
    files), made once for the tests that read it."""

    def build(folder: Path) -> None:
        import analysis

        analysis.run([SESSIONS], folder / "results", scene=False)

    return built_once(tmp_path_factory, "bundled", build) / "results"
