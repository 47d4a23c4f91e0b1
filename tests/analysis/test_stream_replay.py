"""A simulated two-camera session replayed: the offset measured, the moving dot estimated
per pair where the truth is, and the touches' errors (issue 58 item 6's start)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from analysis.session.stream import replay_pair_session
from recorder.simulate.pair import PairTiming, simulate_pair_session
from tests.helpers import SMALL_SCENE
from twopose.errors import InputValueError
from twopose.format.reader import SessionReader
from twopose.format.streams import read_pair_session
from twopose.methods.specs import Method
from twopose.pair.clock import ClockOffset
from twopose.sim.scene import load_scene


@pytest.fixture(scope="module")
def moving_dot(tmp_path_factory: pytest.TempPathFactory) -> Path:
    folder = tmp_path_factory.mktemp("replay")
    (folder / "small.toml").write_text(SMALL_SCENE)
    path, scene = folder / "dot.mcap", load_scene(folder / "small.toml")
    timing = PairTiming(speed=10.0, clock_offset_ms=12.5, flash=False)
    simulate_pair_session(path, method=Method.POINT, timing=timing, trials=1, seed=3, scene=scene)
    return path


def _truth_at(path: Path, t_ns: np.ndarray) -> np.ndarray:
    with SessionReader(path) as reader:
        (trial,) = read_pair_session(reader).trials
    truth = trial.trajectory
    assert truth is not None
    t, p = np.array(truth.t_ns, dtype=np.float64), np.array(truth.points)
    return np.column_stack([np.interp(t_ns, t, p[:, i]) for i in range(3)])


def test_the_offset_is_measured_and_the_moving_dot_estimated_where_it_was(
    moving_dot: Path,
) -> None:
    (trial,) = replay_pair_session(moving_dot).trials
    assert trial.offset_from == "measured"  # the simulator writes none
    assert abs(trial.offset.offset_ns - 12.5e6) < max(3 * trial.offset.sigma_ns, 0.5e6)
    estimate = trial.estimate
    assert estimate.ok.mean() > 0.9
    error = np.linalg.norm(estimate.point - _truth_at(moving_dot, estimate.t_ns), axis=1)
    rms = float(np.sqrt(np.nanmean(error[estimate.ok] ** 2)))
    assert rms < 0.03  # inches, the dot moving at 10 in/s (0.021 measured)
    assert trial.touch_error.shape == (4,)
    assert (trial.touch_error < 0.03).all()
    assert trial.reason == ""
    # the offset ignored and camera 1's frame taken as it is: the skew shows on the moving dot
    zero = ClockOffset(offset_ns=0.0, sigma_ns=1e6, method="assumed", n=1)
    (naive,) = replay_pair_session(moving_dot, offset=zero, interpolate=False).trials
    assert naive.offset_from == "given"
    bad = naive.estimate
    skewed = np.linalg.norm(bad.point - _truth_at(moving_dot, bad.t_ns), axis=1)
    assert float(np.sqrt(np.nanmean(skewed[bad.ok] ** 2))) > 3 * rms  # 0.146 measured


def test_a_one_camera_session_is_refused_in_words(tmp_path: Path) -> None:
    from recorder.simulate.one_camera import simulate_session

    path = tmp_path / "one.mcap"
    (tmp_path / "small.toml").write_text(SMALL_SCENE)
    scene = load_scene(tmp_path / "small.toml")
    simulate_session(path, method=Method.POINT, trials=1, frames=1, scene=scene)
    with pytest.raises(InputValueError, match="one-camera session"):
        replay_pair_session(path)


def test_run_takes_a_two_camera_session_as_a_measurement_session(moving_dot: Path) -> None:
    from analysis.batch.inputs import resolve_inputs

    inputs = resolve_inputs([moving_dot])
    assert inputs.empty == ()  # not an empty session: its stream trials are analysed
    assert inputs.files == [str(moving_dot)]
    assert inputs.notes() == []
