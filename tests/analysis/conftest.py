"""Fixtures the analysis tests share."""

from __future__ import annotations

import dataclasses
import sys
from pathlib import Path

import pytest

from recorder.simulate.one_camera import simulate_session
from twopose.methods.specs import Method
from twopose.rig.constants import RigConstants
from twopose.sim.scene import Scene

sys.path.insert(0, str(Path(__file__).resolve().parents[2] / "sessions"))
from make_sessions import THESIS_POSES  # type: ignore[import-not-found]  # on sys.path at run time

from tests.analysis.rig_helpers import RIG
from tests.conftest import built_once


@pytest.fixture(scope="session")
def rig_sessions(tmp_path_factory: pytest.TempPathFactory) -> dict[str, Path]:
    """Two 10-trial point sessions of one seed, simulated with the constants RIG and without
    (about 35 s of rendering: built once per test run, not once per pytest-xdist worker)."""
    names = {"with": RIG, "without": RigConstants()}

    def build(folder: Path) -> None:
        for name, rig in names.items():
            # No typing error: what remains is the constants' bias and the pixels' noise.
            poses = dataclasses.replace(THESIS_POSES, noise_sigma=0.0)
            scene = Scene(poses=poses, systematic=rig)
            path = folder / f"{name}.mcap"
            simulate_session(path, method=Method.POINT, trials=10, frames=2, seed=41, scene=scene)

    folder = built_once(tmp_path_factory, "rig", build)
    return {name: folder / f"{name}.mcap" for name in names}


@pytest.fixture(scope="session")
def mixed_pair_folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    """A folder (read only): a simulated two-camera point session (a dot moving at 10 in/s,
    camera 2's clock 12.5 ms ahead, 4 touches) beside a two-trial one-camera point session."""
    from recorder.simulate.pair import PairTiming, simulate_pair_session
    from tests.helpers import SMALL_SCENE
    from twopose.sim.scene import load_scene

    folder = tmp_path_factory.mktemp("mixed")
    (folder / "small.toml").write_text(SMALL_SCENE)
    scene = load_scene(folder / "small.toml")
    timing = PairTiming(speed=10.0, clock_offset_ms=12.5, flash=False)
    simulate_pair_session(
        folder / "pair.mcap", method=Method.POINT, timing=timing, trials=1, seed=3, scene=scene
    )
    simulate_session(folder / "one.mcap", method=Method.POINT, trials=2, frames=1, scene=scene)
    return folder
