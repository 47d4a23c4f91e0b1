"""Issue 58 (adversarial finding 4): the measured clock offset's sigma is honest on the
simulator's own sessions -- at 100 in/s camera 1's interpolation error between its
frames is carried as a term of the sigma (it was -14.46 +- 0.0024 ms against a true -12.5),
and at 50% dropped frames a mean over a set of frames that changed with the offset made a
false sharp minimum (2.0 +- 7.7e-8 ms against 12.5): now refused in words, or covered."""

from __future__ import annotations

import re
from pathlib import Path

import pytest

import analysis
from analysis.session.stream import replay_pair_session
from recorder.simulate.pair import PairTiming, simulate_pair_session
from twopose.errors import InputValueError
from twopose.methods.specs import Method


@pytest.mark.parametrize(
    ("timing", "seed"),
    [
        (PairTiming(speed=100.0, clock_offset_ms=-12.5), 0),
        (PairTiming(speed=10.0, clock_offset_ms=12.5, drop=0.5), 0),
    ],
)
def test_a_measured_offset_is_within_its_sigma_or_refused(
    tmp_path: Path, timing: PairTiming, seed: int
) -> None:
    path = tmp_path / "s.mcap"
    simulate_pair_session(path, method=Method.POINT, timing=timing, trials=1, seed=seed)
    try:
        trials = replay_pair_session(path).trials
    except InputValueError as err:  # refused in words: an "I can't", never a wrong "ok"
        refused = str(err)
        trials = ()
    else:
        refused = ""
    if not trials:
        assert "the clock offset" in refused
    for trial in trials:
        offset = trial.offset
        error_ms = offset.offset_ns / 1e6 - timing.clock_offset_ms
        assert abs(error_ms) <= 3 * offset.sigma_ns / 1e6, (error_ms, offset)


def test_a_touch_lost_to_a_camera_names_it_and_the_detectors_reason(tmp_path: Path) -> None:
    """Issue 58 (adversarial 12): the README's demo's failed touches said "the nearest
    pair's fewer than two views"; the row names the camera and why its detector refused."""
    path = tmp_path / "demo.mcap"
    timing = PairTiming(speed=10.0, clock_offset_ms=12.5)
    simulate_pair_session(path, method=Method.GROUND, timing=timing, trials=1, seed=0)
    rows = analysis.run([path]).trials
    lost = rows[rows["status"] != "ok"]
    # Two of its four touches are lost to camera 2 (the finger merged with its shadow in
    # the simulator's frames); when the scene is fixed, this test needs another lost touch.
    assert not lost.empty
    for reason in lost["reason"]:
        assert "fewer than two views" not in reason
        assert re.search(r"not detected by camera [12]: \S", reason), reason
